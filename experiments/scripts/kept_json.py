"""What the experiment scripts keep in the repository: a small JSON file per finished piece, with
the machine and binary that made it. Written atomically, so a stop leaves the old file or the new
one. Standard library only."""
import json
import os
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


def write(path, obj):
    os.makedirs(os.path.dirname(os.path.abspath(path)), exist_ok=True)
    with open(path + ".tmp", "w") as f:
        json.dump(obj, f, indent=1, sort_keys=True)
        f.write("\n")
    os.replace(path + ".tmp", path)
    print(f"kept {path}")
