#!/usr/bin/env python3
"""experiments/scripts/residual_verdict.py (notebook 108's rule) on made-up pieces with known answers: nothing
read before all sixteen are in; holds, does not hold, cannot tell; the adoption's conditions; one
line for a bad piece."""
import json
import os
import subprocess
import sys
import tempfile

script = sys.argv[1]


def run(*args):
    return subprocess.run([sys.executable, script, *args], capture_output=True, text=True)


def write(keep, arm, seed, on_line, lanes=0.70, center=0.65, tube=0.4):
    d = os.path.join(keep, arm)
    os.makedirs(d, exist_ok=True)
    json.dump({"ap": lanes, "c": center, "lost": {"tube": tube}}, open(os.path.join(d, f"s{seed}.json"), "w"))
    json.dump({"entries": [{"name": f"s{seed}", "winrate": on_line}, {"name": "autopilot", "winrate": 1 - on_line}]},
              open(os.path.join(d, f"s{seed}_online.json"), "w"))


def arm_pair(keep, diffs, base=0.35, res_lanes=0.70, res_center=0.65):
    for s, dd in enumerate(diffs, start=1):
        write(keep, "ppo", s, base)
        write(keep, "residual", s, base + dd, lanes=res_lanes, center=res_center)


with tempfile.TemporaryDirectory() as tmp:
    spread = [k - 3.5 for k in range(8)]
    early = f"{tmp}/early"
    for s in range(1, 6):
        write(early, "ppo", s, 0.35)
        write(early, "residual", s, 0.60)
    out = run(early)
    assert out.returncode == 0 and "10 of the 16 pre-registered pieces kept" in out.stdout, out
    assert "0.35" not in out.stdout and "0.6" not in out.stdout and "D =" not in out.stdout, out.stdout

    arm_pair(f"{tmp}/holds", [0.20 + 0.01 * k for k in spread])
    out = run(f"{tmp}/holds")
    assert out.returncode == 0 and "D = +0.200" in out.stdout and "**holds**" in out.stdout, out
    assert "Adopted as the default: **yes**" in out.stdout, out.stdout
    assert "| ppo | 0.350 [0.350, 0.350]" in out.stdout, out.stdout

    arm_pair(f"{tmp}/lanes", [0.20 + 0.01 * k for k in spread], res_lanes=0.65)
    out = run(f"{tmp}/lanes")
    assert "**holds**" in out.stdout and "Adopted as the default: **no**" in out.stdout, out.stdout

    arm_pair(f"{tmp}/center", [0.20 + 0.01 * k for k in spread], res_center=0.55)
    assert "Adopted as the default: **no**" in run(f"{tmp}/center").stdout

    arm_pair(f"{tmp}/not", [0.0 + 0.01 * k for k in spread])
    out = run(f"{tmp}/not")
    assert "**does not hold**" in out.stdout and "Adopted as the default: **no**" in out.stdout, out.stdout

    arm_pair(f"{tmp}/cannot", [0.05 + 0.05 * k for k in spread])
    assert "**cannot tell at this power**" in run(f"{tmp}/cannot").stdout

    # --arms: the same rule on other folders (notebook 109's ppo and progress); the arms' roles
    # count: swapped, the holding difference becomes one that does not hold.
    for s, dd in enumerate([0.20 + 0.01 * k for k in spread], start=1):
        write(f"{tmp}/arms", "ppo", s, 0.35)
        write(f"{tmp}/arms", "progress", s, 0.35 + dd)
    out = run("--arms", "ppo", "progress", f"{tmp}/arms")
    assert out.returncode == 0 and "D = +0.200" in out.stdout and "the progress pilot out-flies the ppo one" in out.stdout, out
    assert "**holds**" in out.stdout and "| progress | 0.550" in out.stdout, out.stdout
    out = run("--arms", "progress", "ppo", f"{tmp}/arms")
    assert "D = -0.200" in out.stdout and "**does not hold**" in out.stdout, out.stdout
    out = run(f"{tmp}/arms")  # the default arms: residual/ is missing, so nothing is read
    assert "8 of the 16 pre-registered pieces kept" in out.stdout and "D =" not in out.stdout, out.stdout
    out = run("--arms", "ppo", "ppo", f"{tmp}/arms")
    assert out.returncode != 0 and "usage:" in out.stderr, out

    arm_pair(f"{tmp}/bad", [0.2] * 8)
    json.dump({"seed": 3}, open(f"{tmp}/bad/ppo/s3.json", "w"))
    out = run(f"{tmp}/bad")
    assert out.returncode != 0 and "s3.json: not a kept piece" in out.stderr, out
    assert len(out.stderr.strip().splitlines()) == 1, out.stderr

    arm_pair(f"{tmp}/torn", [0.2] * 8)
    open(f"{tmp}/torn/residual/s2_online.json", "w").write('{"entries": [')
    out = run(f"{tmp}/torn")
    assert out.returncode != 0 and "s2_online.json: unreadable" in out.stderr, out
    assert len(out.stderr.strip().splitlines()) == 1, out.stderr

print("residual_verdict: too few pieces, holds, other arms, the adoption's conditions, does not hold, cannot tell and bad input as expected")
