#!/usr/bin/env python3
"""experiments/scripts/long_race_verdict.py (notebook 106's rule) on made-up kept seeds with known answers.

Short arm: e = 0.60 + 0.01 k (k = -3.5 .. 3.5 over eight seeds). Long arm: e 0.15 higher,
finishing 0.98 of its races and beating the autopilot 0.62 + 0.005 k: the difference holds and the
low level keeps issue 50's conditions, so the long tracks are adopted. The same long arm finishing
0.90: not adopted. A long arm equal to the short one: D = 0, its CI within +-0.05 (the arms are
resampled apart, so it has a width): "does not hold".
"""
import json
import os
import subprocess
import sys
import tempfile

SCRIPT = sys.argv[1]


def write_arm(folder, e_shift, finish, ap):
    os.makedirs(folder)
    for s in range(1, 9):
        k = s - 4.5
        m = dict(row=f"| {s} |", c=0.60 + 0.01 * k + e_shift, r=0.7, ap=ap + 0.005 * k, finish=finish,
                 center_median_s=30.0, blocks_vs_center=0.1, lost={}, clean=0.5, v=620.0)
        json.dump(m, open(os.path.join(folder, f"s{s}.json"), "w"))


def run(*args):
    return subprocess.run([sys.executable, SCRIPT, *args], capture_output=True, text=True)


with tempfile.TemporaryDirectory() as tmp:
    write_arm(f"{tmp}/short", 0.0, 0.99, 0.65)
    write_arm(f"{tmp}/long", 0.15, 0.98, 0.62)
    write_arm(f"{tmp}/long_unfinished", 0.15, 0.90, 0.62)
    write_arm(f"{tmp}/same", 0.0, 0.99, 0.65)
    out = run(f"{tmp}/short", f"{tmp}/long")
    assert out.returncode == 0, out
    assert "D = e(long) - e(short) = +0.150" in out.stdout and "**holds**" in out.stdout, out.stdout
    assert "keeps issue 50's conditions" in out.stdout and "**Adopt the long tracks" in out.stdout, out.stdout
    assert "| e: vs own @center | 0.600 |" in out.stdout, out.stdout
    out = run(f"{tmp}/short", f"{tmp}/long_unfinished")
    assert "**holds**" in out.stdout and "does not keep" in out.stdout and "**The default stays**" in out.stdout, out.stdout
    out = run(f"{tmp}/short", f"{tmp}/same")
    assert "= +0.000, bootstrap 95 % [-0.022, +0.022]" in out.stdout and "**does not hold**" in out.stdout, out.stdout
    # Seeds kept before `finish` was kept are refused in one line, naming the folder.
    m = json.load(open(f"{tmp}/long/s3.json"))
    del m["finish"]
    json.dump(m, open(f"{tmp}/long/s3.json", "w"))
    bad = run(f"{tmp}/short", f"{tmp}/long")
    assert bad.returncode != 0 and f"{tmp}/long: 1 kept seeds lack `finish`" in bad.stderr, bad
    assert run(f"{tmp}/short").returncode != 0
print("long_race_verdict: all verdicts as constructed")
