#!/usr/bin/env python3
"""experiments/scripts/study_verdicts.py on synthetic studies whose answers are known by construction.

Pilot A: run strength es 0, es_d1 0.05, es_d2 0.12, es_d3 0.20 (pairing winrate 0.5 + a_i - a_j),
the same at both intervals; every run beats its @center 0.70 and @random 0.80 and blocks 2 per
race against the center line's 1. So (a), (b), (c), (c'), (d) hold, and (e2) does not (ES+D2's
shortfall is the same at 8 s and 20 s). Pilot B: every variant equal, every run at 0.50 against
its controls and blocking as they do: nothing holds, and across pilots (a) "does not hold
(depends on the pilot)".
"""
import csv
import os
import subprocess
import sys
import tempfile

SCRIPT = sys.argv[1]
VARIANTS = ["es", "es_d1", "es_d2", "es_d3"]


def write_study(root, strength, vs_center, vs_random, blocks, center_blocks, seeds=range(1, 6)):
    for dt in (8, 20):
        runs = [f"{v}_s{s}" for v in VARIANTS for s in seeds]
        a = {r: strength[r.rsplit("_s", 1)[0]] + 0.004 * (int(r.rsplit("_s", 1)[1]) - 3) for r in runs}
        os.makedirs(f"{root}/dt{dt}/tournament")
        with open(f"{root}/dt{dt}/tournament/pairings.csv", "w", newline="") as f:
            w = csv.writer(f)
            w.writerow(["row", "column", "winrate", "races", "wilson95_lo", "wilson95_hi", "row_entry",
                        "column_entry"])
            for i, x in enumerate(runs):
                for j, y in enumerate(runs):
                    if i < j:
                        w.writerow([i, j, 0.5 + a[x] - a[y], 32, 0, 1, x, y])
        open(f"{root}/dt{dt}/tournament/done.txt", "w").close()
        for r in runs:
            os.makedirs(f"{root}/dt{dt}/{r}")
            c = f"{root}/dt{dt}/controls/{r}"
            os.makedirs(c)
            with open(f"{c}/pairings.csv", "w", newline="") as f:
                w = csv.writer(f)
                w.writerow(["row", "column", "winrate", "races", "wilson95_lo", "wilson95_hi", "row_entry",
                            "column_entry"])
                w.writerow([0, 1, vs_center, 512, 0, 1, r, r + "@center"])
                w.writerow([0, 2, vs_random, 512, 0, 1, r, r + "@random"])
                w.writerow([1, 2, 0.6, 512, 0, 1, r + "@center", r + "@random"])
            with open(f"{c}/races.csv", "w", newline="") as f:
                w = csv.writer(f)
                w.writerow(["pair", "race", "blue", "red", "blue_blocks", "red_blocks"])
                for k in range(16):
                    run_blue = k % 2 == 0
                    blue, red = (r, r + "@center") if run_blue else (r + "@center", r)
                    bb, rb = (blocks, center_blocks) if run_blue else (center_blocks, blocks)
                    w.writerow([0, k, blue, red, bb, rb + (k % 3 == 0)])
                w.writerow([1, 0, r + "@center", r + "@random", 9, 9])  # another pairing: not counted
            open(f"{c}/done.txt", "w").close()


def row(text, claim, dt):
    for line in text.splitlines():
        if line.startswith(f"| ({claim}) ") and f"| {dt} s |" in line:
            return [c.strip() for c in line.strip("|").split("|")]
    raise AssertionError(f"no verdict row for ({claim}) at {dt} s in:\n{text}")


with tempfile.TemporaryDirectory() as tmp:
    write_study(f"{tmp}/A", {"es": 0.0, "es_d1": 0.05, "es_d2": 0.12, "es_d3": 0.20}, 0.70, 0.80, 2, 1)
    write_study(f"{tmp}/B", {v: 0.0 for v in VARIANTS}, 0.50, 0.50, 1, 1)
    one = subprocess.run([sys.executable, SCRIPT, f"{tmp}/A"], capture_output=True, text=True, check=True).stdout
    for claim in ("a", "b", "c", "c'", "d"):
        for dt in (8, 20):
            r = row(one, claim, dt)
            assert r[2] == "holds" and r[3] == "pilot A only: holds", (claim, dt, r)
    assert row(one, "e", 20)[2] == "does not hold", row(one, "e", 20)
    assert "| es_d3 > es_d2 | 0.580 |" in one, one
    both = subprocess.run([sys.executable, SCRIPT, f"{tmp}/A", f"{tmp}/B"], capture_output=True, text=True,
                          check=True).stdout
    for claim in ("a", "b", "c", "d"):
        r = row(both, claim, 8)
        assert r[2] == "holds" and r[3] == "does not hold", (claim, r)
        assert r[4] == "does not hold (depends on the pilot)", (claim, r)
    # A study with a missing interval says so instead of guessing.
    os.remove(f"{tmp}/B/dt20/tournament/pairings.csv")
    part = subprocess.run([sys.executable, SCRIPT, f"{tmp}/B"], capture_output=True, text=True, check=True).stdout
    assert row(part, "a", 20)[2] == "missing", row(part, "a", 20)
    assert "round robin not raced yet" in part
    bad = subprocess.run([sys.executable, SCRIPT, f"{tmp}/nothing"], capture_output=True, text=True)
    assert bad.returncode != 0 and "not a study folder" in bad.stderr, bad

# Notebook 72's blocks: one study per seed, kept as sS.json, read as a blocked study. Same
# strengths as pilot A above, so the same verdicts; M(u, v) over same-seed pairings cancels the
# seed's own offset, and (e2) resamples the same seeds at both intervals (a difference of 0 in
# every replicate: "does not hold").
with tempfile.TemporaryDirectory() as tmp:
    strength = {"es": 0.0, "es_d1": 0.05, "es_d2": 0.12, "es_d3": 0.20}
    for seed in range(1, 9):
        write_study(f"{tmp}/block{seed}", strength, 0.70, 0.80, 2, 1, seeds=[seed])
        subprocess.run([sys.executable, SCRIPT, "--keep-block", f"{tmp}/block{seed}", f"{tmp}/kept"],
                       capture_output=True, text=True, check=True)
    blocked = subprocess.run([sys.executable, SCRIPT, f"{tmp}/kept"], capture_output=True, text=True,
                             check=True).stdout
    for claim in ("a", "b", "c", "c'", "d"):
        for dt in (8, 20):
            assert row(blocked, claim, dt)[2] == "holds", (claim, dt, row(blocked, claim, dt))
    assert "| es_d3 > es_d2 | 0.580 | [0.580, 0.580] |" in blocked, blocked
    # Panels: es_d3's pairings are 0.5 + 0.20 - a_v (0.70, 0.65, 0.58) in every seed, so its IQM over
    # 8 seeds x 3 = 24 values cuts 6 from each end, leaving two 0.58, eight 0.65 and two 0.70:
    # 7.76 / 12 = 0.647; its total winrate is the plain mean, 0.643.
    assert "| es_d3 | 8 | 0.643 ± 0.000 | 0.647 [0.647, 0.647] |" in blocked, blocked
    assert "| es_d3 | 0.700 | 0.650 | 0.580 |  |" in blocked, blocked
    assert "**Provisional**: pilot A has 8 of the 24 pre-registered blocks" in blocked, blocked
    assert "same-seed pairings" in blocked and "runs per variant: es 8," in blocked, blocked
    assert "(e2) ES+D2's shortfall against ES+D3, 8 s minus 20 s: 95 % CI [+0.000, +0.000]" in blocked, blocked
    # A block is one seed, finished: two seeds, or a run without its controls, are refused in one line.
    write_study(f"{tmp}/two", strength, 0.70, 0.80, 2, 1, seeds=[1, 2])
    two = subprocess.run([sys.executable, SCRIPT, "--keep-block", f"{tmp}/two", f"{tmp}/k2"], capture_output=True,
                         text=True)
    assert two.returncode != 0 and "one seed's study" in two.stderr and not os.path.exists(f"{tmp}/k2"), two
    os.remove(f"{tmp}/block1/dt20/controls/es_d2_s1/done.txt")
    part = subprocess.run([sys.executable, SCRIPT, "--keep-block", f"{tmp}/block1", f"{tmp}/k3"],
                          capture_output=True, text=True)
    assert part.returncode != 0 and "dt20/controls/es_d2_s1: no done.txt" in part.stderr, part
print("study_verdicts: all synthetic verdicts as constructed")
