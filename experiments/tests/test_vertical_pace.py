#!/usr/bin/env python3
"""experiments/scripts/vertical_pace.py (notebook 96) on stand-in inputs whose answers are known: exact
correlations and slopes over pilots built on a line, per-seed scores against the shifted autopilot
(a draw half a win, the autopilot's tube losses counted on its own side), the paired difference;
one line and exit 1 on a missing or malformed input."""
import csv
import json
import os
import subprocess
import sys
import tempfile

script = sys.argv[1]
failures = []


def check(ok, what):
    print(("ok    " if ok else "FAIL  ") + what)
    if not ok:
        failures.append(what)


def run(*args):
    return subprocess.run([sys.executable, script, *args], capture_output=True, text=True)


def races(folder, seed, wins, draws, ap_tube_races):
    """Ten races of s<seed> against the autopilot, sides alternating: `wins` won, `draws` drawn; the
    autopilot loses one aircraft to the tube in the first `ap_tube_races` races, the run in all."""
    os.makedirs(folder)
    with open(os.path.join(folder, "races.csv"), "w", newline="") as f:
        w = csv.writer(f)
        w.writerow(["blue", "red", "winner", "blue_out_tube", "red_out_tube"])
        for k in range(10):
            me = f"s{seed}"
            winner = me if k < wins else ("draw" if k < wins + draws else "autopilot")
            ap_out = int(k < ap_tube_races)
            if k % 2 == 0:
                w.writerow([me, "autopilot", winner, 1, ap_out])
            else:
                w.writerow(["autopilot", me, winner, ap_out, 1])


with tempfile.TemporaryDirectory() as tmp:
    # Pilots on exact lines: airspeed = 620 - 4 up, winrate = 0.5 + 0.1 (airspeed - 620).
    arm = os.path.join(tmp, "arm")
    os.makedirs(arm)
    for s, up in enumerate([-0.3, -0.1, 0.0, 0.2, 0.4], start=1):
        v = 620.0 - 4.0 * up
        json.dump({"center_offset": {"up": up}, "v": v, "ap": 0.5 + 0.1 * (v - 620.0)}, open(os.path.join(arm, f"s{s}.json"), "w"))
    out = run("pilots", arm)
    check(out.returncode == 0, f"pilots: exit {out.returncode} {out.stderr.strip()}")
    check("corr(up, airspeed): -1.00 bootstrap 95% [-1.00, -1.00]" in out.stdout, "a falling line has correlation -1")
    check("corr(airspeed, vs autopilot): +1.00" in out.stdout, "a rising line has correlation +1")
    check("slope: airspeed -4.00 ft/s per R of vertical offset; vs autopilot +0.100 per ft/s" in out.stdout, "the slopes")
    check("5 pilots" in out.stdout, "counts the pilots")

    root = os.path.join(tmp, "shifts")
    for s in range(1, 9):
        races(os.path.join(root, "shift0", f"t_s{s}"), s, wins=7, draws=0, ap_tube_races=0)
        races(os.path.join(root, "shift-0.3", f"t_s{s}"), s, wins=4, draws=2 if s <= 4 else 0, ap_tube_races=3)
    out = run("shifts", root, "0", "-0.3")
    check(out.returncode == 0, f"shifts: exit {out.returncode} {out.stderr.strip()}")
    lines = out.stdout.splitlines()
    check("| 1 | 0.700 (0.000) | 0.500 (0.300) |" in lines, "seed 1: 7 of 10, then 4 won and 2 drawn; the autopilot's tube losses on its own side")
    check("| 8 | 0.700 (0.000) | 0.400 (0.300) |" in lines, "seed 8: 4 of 10")
    check("| mean | 0.700 (0.000) | 0.450 (0.300) |" in lines, "the means")
    diff = [l for l in lines if l.startswith("moved -0.3 R minus moved 0 R")]
    # Differences -0.2 (seeds 1-4) and -0.3 (5-8): the bootstrap's means lie between them, about the mean.
    ok = len(diff) == 1 and "-0.250 bootstrap 95% [" in diff[0] and "lower in 8 of 8" in diff[0]
    if ok:
        lo, hi = (float(x) for x in diff[0].split("[")[1].split("]")[0].split(", "))
        ok = -0.3 < lo < -0.25 < hi < -0.2
    check(ok, f"the paired difference and its bootstrap interval: {diff}")

    # A treatment whose runs score 0.9 at shift 0 and 0.8 at -0.3: its tuned autopilot is -0.3 R
    # (mean 0.8), the control's also -0.3 R (0.45); every treatment seed meets Claim A
    # (0.8 of 10 races has its Wilson bound at 0.49: 10 races are too few), none of the control's.
    treat = os.path.join(tmp, "treat")
    for s in range(1, 9):
        races(os.path.join(treat, "shift0", f"t_s{s}"), s, wins=9, draws=0, ap_tube_races=0)
        races(os.path.join(treat, "shift-0.3", f"t_s{s}"), s, wins=8, draws=0, ap_tube_races=0)
    out = run("tuned", root, treat, "0", "-0.3")
    check(out.returncode == 0, f"tuned: exit {out.returncode} {out.stderr.strip()}")
    check("control: tuned autopilot moved -0.3 R; the runs' mean 0.450; Claim A 0 of 8" in out.stdout, "the control's tuned shift")
    check("treatment: tuned autopilot moved -0.3 R; the runs' mean 0.800; Claim A 0 of 8" in out.stdout,
          "the treatment's tuned shift; 10 races cannot clear the bar")
    diff = [l for l in out.stdout.splitlines() if l.startswith("treatment - control")]
    ok = len(diff) == 1 and ": +0.350 bootstrap 95% [" in diff[0]
    if ok:
        lo, hi = (float(x) for x in diff[0].split("[")[1].split("]")[0].split(", "))
        ok = 0.3 <= lo < 0.35 < hi <= 0.4  # the control's seeds are 0.5 or 0.4, the treatment's all 0.8
    check(ok, f"the difference of the arms and its interval: {diff}")

    out = run("shifts", root, "0", "-0.5")
    check(out.returncode == 1 and out.stderr.count("\n") == 1 and "shift-0.5/t_s1/races.csv" in out.stderr,
          f"a missing shift: one line naming the file: {out.stderr.strip()}")
    bad = os.path.join(tmp, "bad")
    os.makedirs(bad)
    json.dump({"v": 620}, open(os.path.join(bad, "s1.json"), "w"))
    out = run("pilots", bad)
    check(out.returncode == 1 and out.stderr.count("\n") == 1 and "s1.json" in out.stderr, f"a summary without center_offset: {out.stderr.strip()}")
    out = run("nonsense")
    check(out.returncode == 1 and "usage" in out.stderr, "usage on a bad command")

sys.exit(1 if failures else 0)
