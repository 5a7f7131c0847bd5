"""What the experiment scripts keep in the repository: a small JSON file per finished piece, with
the machine and binary that made it. Written atomically, so a stop leaves the old file or the new
one. Standard library only."""
import json
import os
import re
import subprocess


def cpu_model():
    """The model name with its family and model numbers: trained weights depend on the CPU's
    kernels, and one name ("AMD EPYC") covers several generations."""
    fields = {}
    for line in open("/proc/cpuinfo"):
        key, _, value = line.partition(":")
        key = key.strip()
        if key in ("model name", "cpu family", "model") and key not in fields:
            fields[key] = value.strip()
        if not line.strip() and fields:
            break
    name = fields.get("model name", "unknown")
    if "cpu family" in fields and "model" in fields:
        name += f" (family {fields['cpu family']} model {fields['model']})"
    return name


def provenance():
    """The CPU, and the binary that F16RACE names (its --version), when it names one."""
    out = {"cpu": cpu_model()}
    binary = os.environ.get("F16RACE")
    if binary:
        out["binary"] = subprocess.run([binary, "--version"], capture_output=True, text=True).stdout.strip()
    return out


def load_pieces(keep_dir, keys, writer):
    """The kept pieces KEEP_DIR/sS.json, sorted by seed; each must hold `keys` (with "seed").
    Exits in one line naming the file for a folder that is not there, a piece that does not
    parse or lacks a key, or no piece at all; `writer` names the command that keeps them."""
    if not os.path.isdir(keep_dir):
        raise SystemExit(f"{keep_dir}: not a folder of kept pieces ({writer} --keep-piece writes them)")
    pieces = []
    for name in sorted(os.listdir(keep_dir)):
        if re.fullmatch(r"s\d+\.json", name):
            try:
                with open(os.path.join(keep_dir, name)) as f:
                    p = json.load(f)
            except (ValueError, OSError) as e:
                raise SystemExit(f"{keep_dir}/{name}: unreadable ({e}); keep the piece again with --keep-piece")
            if not isinstance(p, dict) or not set(keys) <= set(p):
                raise SystemExit(f"{keep_dir}/{name}: not a kept piece (keys {', '.join(keys)}); keep it again")
            pieces.append(p)
    if not pieces:
        raise SystemExit(f"{keep_dir}: no sS.json piece kept yet")
    return sorted(pieces, key=lambda p: p["seed"])


def write(path, obj):
    os.makedirs(os.path.dirname(os.path.abspath(path)), exist_ok=True)
    with open(path + ".tmp", "w") as f:
        json.dump(obj, f, indent=1, sort_keys=True)
        f.write("\n")
    os.replace(path + ".tmp", path)
    print(f"kept {path}")
