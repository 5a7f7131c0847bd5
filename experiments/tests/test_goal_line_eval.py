#!/usr/bin/env python3
"""experiments/scripts/goal_line_eval.py on stand-in tournaments whose answer is known. Two seeds; per seed
and tournament, 4 races of sS@center against the autopilot and 4 of sS against it.
Seed 1: without the line @center wins 1 of 4, with it 3 of 4 and loses one aircraft to the tube
in one race. Seed 2: without 2 of 4, with 4 of 4, no losses. So @center's difference is +0.5
(seed 1) and +0.5 (seed 2): mean +0.5, interval [0.5, 0.5]; tube losses +0.25 and 0: mean
+0.125, above the guard's 0.1 only in seed 1 (upper bound 0.25): "the margin without the
guard". sS: 2 of 4 in every tournament: difference 0."""
import csv
import json
import os
import subprocess
import sys
import tempfile

SCRIPT = sys.argv[1]
CAUSES = ["team_collision", "collision", "tube", "altitude", "load", "turn_rate", "simulator", "envelope"]


def tournament(path, races):
    os.makedirs(path)
    cols = ["blue", "red", "winner", "blue_terminated", "red_terminated", "duration_s"] + \
        [f"{side}_out_{c}" for side in ("blue", "red") for c in CAUSES]
    with open(os.path.join(path, "races.csv"), "w", newline="") as f:
        w = csv.DictWriter(f, cols)
        w.writeheader()
        for me, won, tube in races:
            r = {c: 0 for c in cols}
            r.update(blue=me, red="autopilot", winner=me if won else "autopilot", duration_s=45.0)
            r["blue_out_tube"] = tube
            r["blue_terminated"] = tube
            w.writerow(r)
    open(os.path.join(path, "done.txt"), "w").write("done\n")


def races(seed, center_wins, tube_races):
    c = f"s{seed}@center"
    out = [(c, k < center_wins, 1 if k < tube_races else 0) for k in range(4)]
    return out + [(f"s{seed}", k < 2, 0) for k in range(4)]


with tempfile.TemporaryDirectory() as root:
    without, with_ = os.path.join(root, "without"), os.path.join(root, "with")
    tournament(os.path.join(without, "t_s1"), races(1, 1, 0))
    tournament(os.path.join(without, "t_s2"), races(2, 2, 0))
    tournament(os.path.join(with_, "line_s1"), races(1, 3, 1))
    tournament(os.path.join(with_, "line_s2"), races(2, 4, 0))
    os.makedirs(os.path.join(with_, "line_s3"))  # unfinished: not counted
    out = os.path.join(root, "eval.json")
    r = subprocess.run([sys.executable, SCRIPT, without, with_, "--json", out], capture_output=True, text=True)
    assert r.returncode == 0, r.stderr
    j = json.load(open(out))
    assert j["seeds"] == [1, 2], j["seeds"]
    c = j["summary"]["sS@center"]
    assert abs(c["mean_difference"]["winrate"] - 0.5) < 1e-12, c
    assert c["ci95"]["winrate"] == [0.5, 0.5], c["ci95"]
    assert abs(c["mean_difference"]["lost_tube"] - 0.125) < 1e-12, c
    assert abs(c["ci95"]["lost_tube"][1] - 0.25) < 1e-12, c["ci95"]
    assert abs(j["summary"]["sS"]["mean_difference"]["winrate"]) < 1e-12, j["summary"]["sS"]
    assert j["verdict"] == "the margin without the guard: the losses are the next question", j["verdict"]
    assert "2 seeds: [1, 2]" in r.stdout, r.stdout
    for args, says in [((without,), "usage"), ((without, os.path.join(root, "none")), "no such folder"),
                       ((with_, without), "no seed")]:
        r = subprocess.run([sys.executable, SCRIPT, *args], capture_output=True, text=True)
        assert r.returncode != 0 and says in r.stderr and len(r.stderr.strip().splitlines()) == 1, (args, r.stderr)
print("goal_line_eval.py: OK")
