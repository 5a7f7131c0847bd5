"""What the experiment scripts keep in the repository: a small JSON file per finished piece, with
the machine and binary that made it. Written atomically, so a stop leaves the old file or the new
one. Standard library only."""
import json
import os
import subprocess


def cpu_model():
    for line in open("/proc/cpuinfo"):
        if line.startswith("model name"):
            return line.split(":", 1)[1].strip()
    return "unknown"


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
