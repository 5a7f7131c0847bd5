#!/usr/bin/env python3
"""experiments/scripts/on_line_table.py (notebook 90's table) on stand-in tournaments whose answers are known:
per seed the run's score against the autopilot (a draw half a win), both teams' tube losses per
race and the clean-race score; the mean over seeds; one line and exit 1 on a folder that is not a
tournament."""
import csv
import os
import subprocess
import sys
import tempfile

script = sys.argv[1]
sys.path.insert(0, os.path.dirname(os.path.abspath(script)))
from pilot_seeds_table import CAUSES  # noqa: E402

failures = []


def check(ok, what):
    print(("ok    " if ok else "FAIL  ") + what)
    if not ok:
        failures.append(what)


def fake_tournament(folder, me, wins, draws, run_side):
    """Ten races of `me` against the autopilot: `wins` won, `draws` drawn, the rest lost. The run
    loses an aircraft to the tube in races 0 and 1 (so they are not clean), the autopilot in race 9."""
    os.makedirs(folder)
    cols = ["blue", "red", "winner", "duration_s", "blue_terminated", "red_terminated"] + \
        [f"{t}_out_{c}" for t in ("blue", "red") for c in CAUSES]
    with open(os.path.join(folder, "races.csv"), "w", newline="") as f:
        w = csv.writer(f)
        w.writerow(cols)
        for k in range(10):
            winner = me if k < wins else ("draw" if k < wins + draws else "autopilot")
            run_out, ap_out = int(k < 2), int(k == 9)
            blue, red = (me, "autopilot") if run_side == "blue" else ("autopilot", me)
            b_out, r_out = (run_out, ap_out) if run_side == "blue" else (ap_out, run_out)
            outs = [str(b_out if (t == "blue" and c == "tube") else (r_out if (t == "red" and c == "tube") else 0))
                    for t in ("blue", "red") for c in CAUSES]
            w.writerow([blue, red, winner, "40", str(b_out), str(r_out)] + outs)


with tempfile.TemporaryDirectory() as tmp:
    a, b = os.path.join(tmp, "s1"), os.path.join(tmp, "s2")
    fake_tournament(a, "es_s1", wins=6, draws=2, run_side="blue")  # 7 of 10; clean races 2-8: 4 won, 2 drawn, 1 lost
    fake_tournament(b, "es_s2", wins=3, draws=0, run_side="red")   # 3 of 10; clean races 2-8: 1 won
    out = subprocess.run([sys.executable, script, a, b], capture_output=True, text=True)
    check(out.returncode == 0, f"two seeds: exit {out.returncode} {out.stderr.strip()}")
    lines = out.stdout.splitlines()
    rows = [ln for ln in lines if ln.startswith("| 1 ") or ln.startswith("| 2 ")]
    check(len(rows) == 2, f"a row per seed: {rows}")
    if len(rows) == 2:
        c1 = [x.strip() for x in rows[0].strip("|").split("|")]
        c2 = [x.strip() for x in rows[1].strip("|").split("|")]
        check(c1[1].startswith("0.700 ["), f"seed 1's score, draws half a win: {c1[1]}")
        check(c1[1] == "0.700 [0.397, 0.892]", f"seed 1's Wilson interval on 7 of 10: {c1[1]}")
        check(c1[2] == "0.200 / 0.100", f"seed 1's tube losses, run / autopilot: {c1[2]}")
        check(c1[4] == "0.714 (7)", f"seed 1's clean races (5 of 7): {c1[4]}")
        check(c2[1].startswith("0.300 ["), f"seed 2 on the red side: {c2[1]}")
        check(c2[2] == "0.200 / 0.100", f"seed 2's tube losses read from its own side: {c2[2]}")
        check(c2[4] == "0.143 (7)", f"seed 2's clean races (1 of 7): {c2[4]}")
    mean = [ln for ln in lines if ln.startswith("mean over seeds")]
    check(bool(mean) and mean[0].startswith("mean over seeds 0.500, bootstrap 95 % [0.300, 0.700]"),
          f"the mean over seeds and its bootstrap: {mean}")

    for bad, what in ((os.path.join(tmp, "nothing"), "a missing folder"), (tmp, "a folder without races.csv")):
        out = subprocess.run([sys.executable, script, bad], capture_output=True, text=True)
        err = out.stderr.strip().splitlines()
        check(out.returncode == 1 and len(err) == 1 and "races.csv" in err[0], f"{what}: exit {out.returncode}, {err}")
    foreign = os.path.join(tmp, "foreign")
    os.makedirs(foreign)
    open(os.path.join(foreign, "races.csv"), "w").write("blue,red,winner\nes_s1,autopilot,es_s1\n")
    out = subprocess.run([sys.executable, script, foreign], capture_output=True, text=True)
    err = out.stderr.strip().splitlines()
    check(out.returncode == 1 and len(err) == 1 and "not a tournament" in err[0], f"a foreign races.csv: {err}")
    open(os.path.join(foreign, "races.csv"), "w").write("name,score\nx,1\n")  # no entry columns at all
    out = subprocess.run([sys.executable, script, foreign], capture_output=True, text=True)
    err = out.stderr.strip().splitlines()
    check(out.returncode == 1 and len(err) == 1 and "not a tournament" in err[0], f"a csv without entries: {err}")

sys.exit(1 if failures else 0)
