#!/usr/bin/env python3
"""experiments/scripts/study_figures.py on synthetic kept blocks whose panel values are known by construction.

Eight blocks; run strength es 0, es_d1 0.05, es_d2 0.12, es_d3 0.20 (pairing winrate 0.5 + a_u - a_v
in every seed). At 8 s every run beats its @center 0.70 and its @random 0.80; at 20 s variant i
(es = 0 .. es_d3 = 3) beats its @center 0.60 + 0.02 i. So es_d3 at 8 s: total winrate 0.643 ± 0,
IQM 0.647 (study_verdicts' test explains both), M(es_d3, es) = 0.70, vs @center 0.70 with a CI of
zero width; es_d1 at 20 s vs @center 0.62.
"""
import csv
import json
import os
import shutil
import subprocess
import sys
import tempfile

SCRIPT = sys.argv[1]
VARIANTS = ["es", "es_d1", "es_d2", "es_d3"]
STRENGTH = {"es": 0.0, "es_d1": 0.05, "es_d2": 0.12, "es_d3": 0.20}


def block(seed):
    intervals = {}
    for dt in (8, 20):
        runs = [f"{v}_s{seed}" for v in VARIANTS]
        pairings = [[a, b, 0.5 + STRENGTH[a.rsplit("_s", 1)[0]] - STRENGTH[b.rsplit("_s", 1)[0]]]
                    for i, a in enumerate(runs) for j, b in enumerate(runs) if i < j]
        controls = {r: dict(vs_center=0.70 if dt == 8 else 0.60 + 0.02 * i, vs_random=0.80, block_diff_sum=512,
                            center_blocks_sum=512, races=512) for i, r in enumerate(runs)}
        intervals[str(dt)] = dict(pairings=pairings, controls=controls)
    return dict(seed=seed, intervals=intervals, cpu="synthetic")


def rows(path):
    with open(path) as f:
        return list(csv.DictReader(f))


with tempfile.TemporaryDirectory() as tmp:
    os.makedirs(f"{tmp}/kept")
    for s in range(1, 9):
        with open(f"{tmp}/kept/s{s}.json", "w") as f:
            json.dump(block(s), f)
    done = subprocess.run([sys.executable, SCRIPT, f"{tmp}/fig", f"{tmp}/kept"], capture_output=True, text=True)
    has_gnuplot = shutil.which("gnuplot") is not None
    assert done.returncode == (0 if has_gnuplot else 1), done
    panels = {(r["pilot"], r["dt_hl_s"], r["variant"]): r for r in rows(f"{tmp}/fig/fig3_panels.csv")}
    assert len(panels) == 8, sorted(panels)
    d3 = panels[("A", "8", "es_d3")]
    assert (d3["runs"], d3["total_mean"], d3["total_std"], d3["iqm"]) == ("8", "0.6433", "0.0000", "0.6467"), d3
    assert (d3["vs_center"], d3["vs_center_lo"], d3["vs_center_hi"], d3["vs_random"]) == (
        "0.7000", "0.7000", "0.7000", "0.8000"), d3
    assert panels[("A", "20", "es_d1")]["vs_center"] == "0.6200", panels[("A", "20", "es_d1")]
    matrix = {(r["pilot"], r["dt_hl_s"], r["row_variant"], r["column_variant"]): r
              for r in rows(f"{tmp}/fig/fig3_matrix.csv")}
    assert len(matrix) == 2 * 12, len(matrix)  # four variants, no diagonal, two intervals
    assert matrix[("A", "8", "es_d3", "es")]["winrate"] == "0.7000"
    assert matrix[("A", "20", "es", "es_d2")]["winrate"] == "0.3800"
    assert (matrix[("A", "8", "es_d3", "es")]["row"], matrix[("A", "8", "es_d3", "es")]["column"]) == ("3", "0")
    if has_gnuplot:
        with open(f"{tmp}/fig/fig3.png", "rb") as f:
            assert f.read(8) == b"\x89PNG\r\n\x1a\n"
        assert os.path.getsize(f"{tmp}/fig/fig3.png") > 20000, os.path.getsize(f"{tmp}/fig/fig3.png")
    # Two pilots draw four rows; a folder that is not kept blocks is refused in one line.
    two = subprocess.run([sys.executable, SCRIPT, f"{tmp}/fig2", f"{tmp}/kept", f"{tmp}/kept"], capture_output=True,
                         text=True)
    assert two.returncode == done.returncode, two
    assert "set multiplot layout 4,4" in open(f"{tmp}/fig2/fig3.gp").read()
    os.makedirs(f"{tmp}/empty")
    bad = subprocess.run([sys.executable, SCRIPT, f"{tmp}/fig3", f"{tmp}/empty"], capture_output=True, text=True)
    assert bad.returncode != 0 and "not a folder of kept blocks" in bad.stderr, bad
print("study_figures: panels and matrix as constructed")
