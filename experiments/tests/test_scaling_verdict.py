#!/usr/bin/env python3
"""experiments/scripts/scaling_verdict.py on synthetic budgets whose answers are known by construction.

Growing: c_i = 0.55 + 0.03 log2(MULT) + a seed offset of +-0.01: the slope is 0.03 per doubling
and every resample keeps it above 0, so "holds". Flat: c_i = 0.60 + the same offsets at every
budget: slope 0 with an interval inside +-0.01, below the 0.0125 bar, so "does not hold". One
budget alone: no slope. A budget without its controls is reported missing.
"""
import csv
import math
import os
import shutil
import subprocess
import sys
import tempfile

SCRIPT = sys.argv[1]
RUNS = [f"{v}_s{s}" for v in ("es_d2", "es_d3") for s in (1, 2, 3)]


def write_budget(root, c_of_seed):
    for r in RUNS:
        c = f"{root}/dt8/controls/{r}"
        os.makedirs(c)
        with open(f"{c}/pairings.csv", "w", newline="") as f:
            w = csv.writer(f)
            w.writerow(["row", "column", "winrate", "races", "wilson95_lo", "wilson95_hi", "row_entry", "column_entry"])
            w.writerow([0, 1, c_of_seed(int(r[-1])), 512, 0, 1, r, r + "@center"])
            w.writerow([0, 2, 0.7, 512, 0, 1, r, r + "@random"])
        with open(f"{c}/races.csv", "w", newline="") as f:
            csv.writer(f).writerows([["pair", "race", "blue", "red", "blue_blocks", "red_blocks"],
                                     [0, 0, r, r + "@center", 1, 1]])
        open(f"{c}/done.txt", "w").close()


def run(args):
    out = subprocess.run([sys.executable, SCRIPT] + args, capture_output=True, text=True)
    if out.returncode != 0:
        sys.exit(f"FAIL: {args}: exit {out.returncode}: {out.stderr}")
    return out.stdout


def expect(cond, what, text):
    if not cond:
        sys.exit(f"FAIL: {what}\n{text}")


with tempfile.TemporaryDirectory() as tmp:
    offset = {1: -0.01, 2: 0.0, 3: 0.01}
    grow, flat = [], []
    for m in (1, 2, 4, 16):
        write_budget(f"{tmp}/grow_x{m}", lambda s, m=m: 0.55 + 0.03 * math.log2(m) + offset[s])
        write_budget(f"{tmp}/flat_x{m}", lambda s: 0.60 + offset[s])
        grow.append(f"{m}={tmp}/grow_x{m}")
        flat.append(f"{m}={tmp}/flat_x{m}")
    text = run(grow)
    expect("slope per doubling of HL env steps: +0.0300" in text and "grows with data: holds" in text, "growing", text)
    expect("| x16 | 28 M | 6 | 0.670 |" in text, "the x16 mean", text)
    text = run(flat)
    expect("+0.0000" in text and "grows with data: does not hold" in text, "flat", text)
    text = run([f"1={tmp}/grow_x1"])
    expect("cannot be computed yet" in text, "one budget", text)
    os.makedirs(f"{tmp}/empty")
    text = run([f"1={tmp}/grow_x1", f"4={tmp}/empty"])
    expect("| x4 | 7 M | 0 | missing |" in text and "missing (6)" in text and "cannot be computed" in text, "missing", text)
    bad = subprocess.run([sys.executable, SCRIPT, f"4={tmp}/nowhere"], capture_output=True, text=True)
    expect(bad.returncode != 0 and "nowhere: want MULT=STUDY_FOLDER" in bad.stderr, "a missing folder", bad.stderr)
    # Kept budgets (--keep) read as their folders did, so the verdict outlives the machine.
    kept = []
    for m in (1, 2, 4, 16):
        run(["--keep", f"{tmp}/grow_x{m}", f"{tmp}/kept/x{m}.json"])
        kept.append(f"{m}={tmp}/kept/x{m}.json")
    expect(run(kept) == run(grow), "kept budgets give the folders' table", run(kept))
    part = subprocess.run([sys.executable, SCRIPT, "--keep", f"{tmp}/empty", f"{tmp}/kept/x3.json"],
                          capture_output=True, text=True)
    expect(part.returncode != 0 and "es_d2_s1: no done.txt" in part.stderr and not os.path.exists(f"{tmp}/kept/x3.json"),
           "an unfinished budget is refused", part.stderr)
    # A budget kept in pieces (--keep-pieces): each piece adds its runs; the whole reads as --keep's.
    for i, r in enumerate(RUNS):
        piece = f"{tmp}/piece{i}/dt8/controls"
        os.makedirs(piece)
        shutil.copytree(f"{tmp}/grow_x16/dt8/controls/{r}", f"{piece}/{r}")
        text = run(["--keep-pieces", f"{tmp}/piece{i}", f"{tmp}/kept/p16.json"])
        expect(f"{i + 1} of 6 runs kept" in text, f"piece {i}", text)
        if i == 2:
            half = run(kept[:3] + [f"16={tmp}/kept/p16.json"])
            expect("| x16 | 28 M | 3 |" in half and "missing (3): x16 es_d3_s1" in half, "half a budget", half)
    expect(run(kept[:3] + [f"16={tmp}/kept/p16.json"]) == run(grow), "pieces give the folder's table", "")
    again = subprocess.run([sys.executable, SCRIPT, "--keep-pieces", f"{tmp}/piece0", f"{tmp}/kept/x16.json"],
                           capture_output=True, text=True)
    expect(again.returncode != 0 and "whole budget" in again.stderr, "pieces into a whole budget's file", again.stderr)
    none = subprocess.run([sys.executable, SCRIPT, "--keep-pieces", f"{tmp}/empty", f"{tmp}/kept/p4.json"],
                          capture_output=True, text=True)
    expect(none.returncode != 0 and "nothing to keep" in none.stderr and not os.path.exists(f"{tmp}/kept/p4.json"),
           "a piece without controls", none.stderr)
print("scaling_verdict: growing holds, flat does not, missing pieces reported, pieces kept")
