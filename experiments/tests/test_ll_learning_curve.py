#!/usr/bin/env python3
"""experiments/scripts/ll_learning_curve.py (notebook 81) on tournaments and curves whose answers are known.

--keep: a stand-in races.csv in which step_0000200000@center meets the autopilot 10 times (it is
blue in 6, red in 4; wins 3; loses 2 aircraft to the tube and 1 to the envelope on its side, while
the autopilot's losses on the other side must not count), and the snapshot itself meets it 4
times (wins 4). Read mode: two seeds whose points lie on known lines."""
import json
import os
import subprocess
import sys
import tempfile

SCRIPT = sys.argv[1]
CAUSES = ["collision", "altitude", "load", "turn_rate", "tube", "simulator", "team_collision", "envelope"]
HEAD = ["pair", "race", "end_reason"] + [f"{s}_out_{c}" for s in ("blue", "red") for c in CAUSES] + ["blue", "red", "winner"]


def row(blue, red, winner, lost=None):
    lost = lost or {}
    r = {"pair": 0, "race": 0, "end_reason": 1, "blue": blue, "red": red, "winner": winner}
    for s in ("blue", "red"):
        for c in CAUSES:
            r[f"{s}_out_{c}"] = lost.get((s, c), 0)
    return ",".join(str(r[h]) for h in HEAD)


def run(*args):
    return subprocess.run([sys.executable, SCRIPT, *args], capture_output=True, text=True)


def one_line_error(r, text):
    assert r.returncode == 2 and text in r.stderr and r.stderr.count("\n") == 1, (r.returncode, r.stderr)


with tempfile.TemporaryDirectory() as tmp:
    snap, ap = "step_0000200000", "autopilot"
    rows = []
    for k in range(6):  # @center blue: wins races 0 and 1; loses 2 aircraft to the tube in race 2
        rows.append(row(snap + "@center", ap, snap + "@center" if k < 2 else ap,
                        {("blue", "tube"): 2, ("red", "tube"): 3} if k == 2 else {}))
    for k in range(4):  # @center red: wins race 0; 1 aircraft to the envelope in race 1
        rows.append(row(ap, snap + "@center", snap + "@center" if k == 0 else ap,
                        {("red", "envelope"): 1, ("blue", "envelope"): 4} if k == 1 else {}))
    for k in range(4):
        rows.append(row(snap, ap, snap))
    rows.append(row(snap, snap + "@center", snap))  # not against the autopilot: not counted
    t = os.path.join(tmp, "t")
    os.makedirs(t)
    open(os.path.join(t, "races.csv"), "w").write(",".join(HEAD) + "\n" + "\n".join(rows) + "\n")
    one_line_error(run("--keep", t, os.path.join(tmp, "k.json")), "not a finished tournament")
    open(os.path.join(t, "done.txt"), "w").write("done\n")
    keep_dir = os.path.join(tmp, "keep")
    out = os.path.join(keep_dir, "s1_step_0000200000.json")
    r = run("--keep", t, out)
    assert r.returncode == 0, r.stderr
    k = json.load(open(out))
    assert k["env_steps"] == 200000, k
    assert k["center"]["races"] == 10 and k["center"]["wins"] == 3, k
    assert k["center"]["lost_per_race"]["tube"] == 0.2 and k["center"]["lost_per_race"]["envelope"] == 0.1, k
    assert k["run"]["races"] == 4 and k["run"]["wins"] == 4, k

    # Read mode: seed 1's points at 2.0, 3.0 M and the final (3.5 M) 0.1, 0.3, 0.4 -> slope 0.2 per
    # M exactly; seed 2's 0.5, 0.4 and 0.35 -> -0.1. Mean +0.05, and the CI of two seeds spans both.
    def point(path, steps, wins):
        json.dump({"env_steps": steps, "center": {"races": 100, "wins": wins, "lost_per_race": {"tube": 0.1}},
                   "run": {"races": 100, "wins": 50, "lost_per_race": {}}}, open(path, "w"))
    os.remove(out)
    point(os.path.join(keep_dir, "s1_step_0002000000.json"), 2_000_000, 10)
    point(os.path.join(keep_dir, "s1_step_0003000000.json"), 3_000_000, 30)
    point(os.path.join(keep_dir, "s2_step_0002000000.json"), 2_000_000, 50)
    point(os.path.join(keep_dir, "s2_step_0003000000.json"), 3_000_000, 40)
    final = os.path.join(tmp, "final")
    os.makedirs(final)
    one_line_error(run(keep_dir, final), "s1.json: missing")
    json.dump({"ll_center_vs_ap": 0.4}, open(os.path.join(final, "s1.json"), "w"))
    json.dump({"ll_center_vs_ap": 0.35}, open(os.path.join(final, "s2.json"), "w"))
    r = run(keep_dir, final)
    assert r.returncode == 0, r.stderr
    assert "| 1 | 2.00: 0.100 (0.10), 3.00: 0.300 (0.10) | 0.400 | +0.200 |" in r.stdout, r.stdout
    assert "| 2 | 2.00: 0.500 (0.10), 3.00: 0.400 (0.10) | 0.350 | -0.100 |" in r.stdout, r.stdout
    assert "2 seeds: mean +0.0500 bootstrap 95% [-0.1000, +0.2000]: flat" in r.stdout, r.stdout
    assert "final minus first point: mean +0.0750" in r.stdout, r.stdout
    # Both seeds rising: still learning.
    point(os.path.join(keep_dir, "s2_step_0003000000.json"), 3_000_000, 45)
    json.dump({"ll_center_vs_ap": 0.6}, open(os.path.join(final, "s2.json"), "w"))
    r = run(keep_dir, final)
    assert r.returncode == 0 and ": still learning" in r.stdout, r.stdout
    one_line_error(run(os.path.join(tmp, "none"), final), "no sS_step_N.json files")
    # A cut-off kept file: one line naming it.
    open(os.path.join(keep_dir, "s3_step_0002000000.json"), "w").write('{"env_steps": 2000000, "center":')
    one_line_error(run(keep_dir, final), "s3_step_0002000000.json: not a kept summary")
    one_line_error(run("--keep", t), "usage")
print("OK")
