#!/usr/bin/env python3
"""experiments/scripts/d3_sensitivity.py (notebook 112's rule) on made-up pieces with known answers.

--keep-piece reads a piece's round robin of six runs and each run's metrics.csv (env steps per ES
update after the first: 100 for d2, 80 for d2_keep); a piece missing a pairing is refused in one
line. The verdict over eight seeds: d3 vs d2 at 0.22; d3_fine 0.10 higher (D3 gains), d3_huber
0.10 lower (D3 loses), d3_keep the same with a spread (not resolved); d2_keep vs d2 at 0.50 +-
0.05 (removed); five seeds print only the count.
"""
import json
import os
import subprocess
import sys
import tempfile

SCRIPT = sys.argv[1]
ARMS = ("d2", "d3", "d3_fine", "d3_huber", "d2_keep", "d3_keep")


def run(*args):
    return subprocess.run([sys.executable, SCRIPT, *args], capture_output=True, text=True)


def write(path, text):
    os.makedirs(os.path.dirname(path), exist_ok=True)
    open(path, "w").write(text)


def make_piece(root, seed, drop=None):
    piece = os.path.join(root, f"s{seed}")
    rows = ["row,column,winrate,races,wilson95_lo,wilson95_hi,row_entry,column_entry"]
    for i, a in enumerate(ARMS):
        for j, b in enumerate(ARMS):
            if a != b and (a, b) != drop:
                w = 0.25 if (a, b) == ("d3", "d2") else (0.75 if (a, b) == ("d2", "d3") else 0.5)
                rows.append(f"{i},{j},{w},512,0,1,{a},{b}")
    write(f"{piece}/tour/pairings.csv", "\n".join(rows) + "\n")
    for a in ARMS:
        step = 80 if a.endswith("keep") else 100
        lines = ["update,phase_hl,env_steps,wall_s"] + [f"{u},1,{150 + step * (u - 1)},{10 * u}" for u in range(1, 6)]
        write(f"{piece}/{a}/metrics.csv", "\n".join(lines) + "\n")
    return piece


def write_kept(folder, n):
    os.makedirs(folder)
    for s in range(1, n + 1):
        e = 0.01 * (s - 4.5) / 3.5  # a small spread around each mean
        w = {"d3|d2": 0.22 + e, "d3_fine|d2": 0.32 + e, "d3_huber|d2": 0.12 + e,
             "d3_keep|d2_keep": 0.22 + 10 * e, "d2_keep|d2": 0.50 + 5 * e}
        runs = {a: dict(env_steps_per_es_update=100.0, wall_s=60.0) for a in ARMS}
        json.dump(dict(seed=s, pairings={k: [v, 512] for k, v in w.items()}, runs=runs, cpu="test"),
                  open(os.path.join(folder, f"s{s}.json"), "w"))


with tempfile.TemporaryDirectory() as tmp:
    out = run("--keep-piece", make_piece(tmp, 3), f"{tmp}/keep")
    assert out.returncode == 0, out
    kept = json.load(open(f"{tmp}/keep/s3.json"))
    assert kept["seed"] == 3 and kept["pairings"]["d3|d2"] == [0.25, 512], kept
    assert kept["runs"]["d2"]["env_steps_per_es_update"] == 100 and kept["runs"]["d3_keep"]["env_steps_per_es_update"] == 80
    assert kept["runs"]["d2"]["wall_s"] == 50.0, kept

    out = run("--keep-piece", make_piece(f"{tmp}/short", 4, drop=("d3_huber", "d2")), f"{tmp}/keep")
    assert out.returncode != 0 and "no pairing d3_huber|d2" in out.stderr, out
    assert len(out.stderr.strip().splitlines()) == 1 and not os.path.exists(f"{tmp}/keep/s4.json"), out

    write_kept(f"{tmp}/five", 5)
    out = run(f"{tmp}/five")
    assert out.returncode == 0 and "5 of the 8" in out.stdout and "0.22" not in out.stdout, out

    write_kept(f"{tmp}/eight", 8)
    out = run(f"{tmp}/eight")
    assert out.returncode == 0, out
    text = out.stdout
    assert "| d3 (the study's) | d2 | 0.220" in text, text
    assert "| d3_fine | d2 | 0.320" in text and "+0.100 [+0.100, +0.100] | **D3 gains**" in text, text
    assert "| d3_huber | d2 | 0.120" in text and "**D3 loses**" in text, text
    assert "| d3_keep | d2_keep | 0.220" in text and "**not resolved**" in text, text
    assert "w(d2_keep, d2) = 0.500" in text and "**removed**" in text, text
print("d3_sensitivity: kept pieces and verdicts as made up")
