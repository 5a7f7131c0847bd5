#!/usr/bin/env python3
"""experiments/scripts/axis_edge.py (notebook 100's rule) on stand-in tournaments whose answers are known: the
pooled head-to-heads of two runs against their axis controls, the three verdicts, a tournament
without axis controls refused in one line, losses by cause and clean races, lateral bins on the inside of a turn, and same-races on
races.csv files that agree in part."""
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


def fake_summary(folder, run, rates, races=400, axes=("center_x", "center_y", "center_z")):
    """`run` against @center and the axis controls at the given winrates, `races` each."""
    os.makedirs(folder)
    choices = {"decisions": 100, "along": [0.5, 0.2, 0.3], "right": [0.1, 0.8, 0.1], "up": [0.7, 0.1, 0.2]}
    entries = [{"name": run, "hl": "policy", "goal_choices": choices}]
    pairings = []
    for rule in ("center",) + axes:
        entries.append({"name": f"{run}@{rule}", "hl": rule, "goal_choices": choices})
        pairings.append({"row": run, "col": f"{run}@{rule}", "races": races, "winrate": rates[rule]})
        pairings.append({"row": f"{run}@{rule}", "col": run, "races": races, "winrate": 1 - rates[rule]})
    with open(os.path.join(folder, "summary.json"), "w") as f:
        json.dump({"entries": entries, "pairings": pairings}, f)


def run(*args):
    return subprocess.run([sys.executable, script, *args], capture_output=True, text=True)


with tempfile.TemporaryDirectory() as tmp:
    a, b = os.path.join(tmp, "a"), os.path.join(tmp, "b")
    # Pooled over 800 races: center 0.70; along 0.50 (none), right 0.56 (part: 0.56 < 0.60),
    # up 0.66 (most: above 0.5 + 0.2 / 2 with its lower bound above 0.5).
    fake_summary(a, "es_d2_s1", {"center": 0.72, "center_x": 0.48, "center_y": 0.57, "center_z": 0.64})
    fake_summary(b, "es_d3_s1", {"center": 0.68, "center_x": 0.52, "center_y": 0.55, "center_z": 0.68})
    r = run("edge", a, b)
    check(r.returncode == 0, f"edge runs: {r.stderr}")
    check("| pooled | 0.700 [" in r.stdout, "pooled vs @center 0.700")
    check("0.660 [" in r.stdout and "0.560 [" in r.stdout, "pooled axis winrates 0.660 (up), 0.560 (right)")
    check("up: carries most of the edge" in r.stdout, "up: most")
    check("right: carries part of the edge" in r.stdout, "right: part")
    check("along: no effect resolved" in r.stdout, "along: none")
    check("0.70 / 0.10 / 0.20" in r.stdout, "up choice shares printed")
    c = os.path.join(tmp, "c")
    fake_summary(c, "es_s1", {"center": 0.7}, axes=())
    r = run("edge", c)
    check(r.returncode != 0 and "has no pairing with @center_x" in r.stderr and len(r.stderr.strip().splitlines()) == 1,
          f"no axis controls refused in one line: {r.stderr!r}")
    log = os.path.join(tmp, "a.log")
    open(log, "w").close()
    r = run("edge", a, log)
    check(r.returncode != 0 and "a.log: no summary.json" in r.stderr and len(r.stderr.strip().splitlines()) == 1,
          f"a file among the folders refused in one line: {r.stderr!r}")

    def races_csv(folder, winners):
        os.makedirs(folder, exist_ok=True)
        with open(os.path.join(folder, "races.csv"), "w", newline="") as f:
            w = csv.writer(f)
            w.writerow(["pair", "race", "duration_s", "blue", "red", "winner"])
            for k, win in enumerate(winners):
                w.writerow([0, k, "100.5", "r", "r@center", win])
    races_csv(os.path.join(tmp, "new"), ["r", "r", "r@center"])
    races_csv(os.path.join(tmp, "old"), ["r", "r", "r", "r"])
    r = run("same-races", os.path.join(tmp, "new"), os.path.join(tmp, "old"))
    check(r.returncode == 1 and "2 of 3 common races" in r.stdout, f"same-races counts: {r.stdout}")
    r = run("same-races", os.path.join(tmp, "old"), os.path.join(tmp, "old"))
    check(r.returncode == 0 and "4 of 4" in r.stdout, "same-races: identical")

    # losses: four races of r against r@center; the run loses one aircraft to the tube in race 0,
    # the control one to a collision in race 1; of the two clean races the control wins one.
    lf = os.path.join(tmp, "losses")
    os.makedirs(lf)
    causes = ["collision", "team_collision", "tube", "envelope"]
    with open(os.path.join(lf, "races.csv"), "w", newline="") as f:
        w = csv.writer(f)
        w.writerow(["blue", "red", "winner", "blue_terminated", "red_terminated"] +
                   [f"{t}_out_{c}" for t in ("blue", "red") for c in causes])
        w.writerow(["r", "r@center", "r@center", 1, 0, 0, 0, 1, 0, 0, 0, 0, 0])
        w.writerow(["r@center", "r", "r", 1, 0, 1, 0, 0, 0, 0, 0, 0, 0])
        w.writerow(["r", "r@center", "r@center", 0, 0, 0, 0, 0, 0, 0, 0, 0, 0])
        w.writerow(["r@center", "r", "r", 0, 0, 0, 0, 0, 0, 0, 0, 0, 0])
    r = run("losses", lf)
    check(r.returncode == 0 and "| r | center | 4 | 0.000, 0.000, 0.250, 0.000 | 0.250, 0.000, 0.000, 0.000 | 0.500 (2) |"
          in r.stdout, f"losses row: {r.stdout}")

    # inside: a track north then a right turn east at s = 10 000; team 0 picks right bins (inside),
    # team 1 left bins (outside) before the turn, and team 0 a right bin after it (no turn ahead:
    # not counted); the middle bin is never counted.
    rf = os.path.join(tmp, "replay")
    os.makedirs(rf)
    with open(os.path.join(rf, "replay_track.csv"), "w") as f:
        f.write("pn_ft,pe_ft,alt_ft,radius_ft\n0,0,10000,1000\n10000,0,10000,1000\n10000,10000,10000,1000\n")
    for a in range(2):
        with open(os.path.join(rf, f"replay_agent{a}.csv"), "w") as f:
            f.write("t_s,s_ft\n0,1000\n8,12000\n")
    with open(os.path.join(rf, "replay_goals.csv"), "w") as f:
        f.write("agent,team,t_s,s_ft,lateral_ft,bin_y\n0,0,0,13000,500,5\n1,1,0,13000,-500,1\n"
                "0,0,8,19000,500,6\n1,1,8,19000,0,3\n")
    r = run("inside", rf)
    check(r.returncode == 0 and "team 0: lateral bin on the inside of the turns ahead in 1 of 1 decisions (1.000)" in r.stdout
          and "team 1: lateral bin on the inside of the turns ahead in 0 of 1 decisions (0.000)" in r.stdout,
          f"inside: {r.stdout}{r.stderr}")

    # The middle bin comes from the file when it says (race.hl_bins 5: middle 2): bin 3 is then right
    # of the middle (inside), and bin 2 is not counted.
    with open(os.path.join(rf, "replay_goals.csv"), "w") as f:
        f.write("agent,team,t_s,s_ft,lateral_ft,bin_y,middle_bin\n0,0,0,13000,500,3,2\n1,1,0,13000,0,2,2\n")
    r = run("inside", rf)
    check(r.returncode == 0 and "team 0: lateral bin on the inside of the turns ahead in 1 of 1 decisions (1.000)" in r.stdout
          and "team 1: lateral bin on the inside of the turns ahead in 0 of 0 decisions\n" in r.stdout,
          f"inside with middle_bin: {r.stdout}{r.stderr}")

if failures:
    sys.exit(f"{len(failures)} check(s) failed")
print("axis_edge: pooled head-to-heads, verdicts, refusals and same-races as expected")
