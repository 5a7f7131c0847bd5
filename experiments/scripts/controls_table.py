#!/usr/bin/env python3
"""Each run against its own controls, from a tournament raced with --controls.

    experiments/scripts/controls_table.py runs/tourney/summary.json

Prints, as Markdown: per run, its head-to-head winrate against RUN@center and RUN@random with a
Wilson 95 % interval, and the round-robin winrates of the run and of its two controls; then the
head-to-heads pooled over the runs (as if their races were exchangeable), how many runs beat
each control, and how the round-robin winrate of the run and control entries splits into a
between-runs part (the low level each seed learned) and a within-run part (the three HL rules
flying the same low level). Standard library only; reads nothing but the summary.json the
tournament wrote (experiments/results/fig3-2core/README.md uses it).
"""
import json
import math
import statistics
import sys


def wilson(wins, n, z=1.959963984540054):
    """Wilson score interval (95 %) for wins out of n; wins may be fractional (draws count half)."""
    if n == 0:
        return (float("nan"), float("nan"))
    p = wins / n
    den = 1 + z * z / n
    centre = (p + z * z / (2 * n)) / den
    half = z * math.sqrt(p * (1 - p) / n + z * z / (4 * n * n)) / den
    return (centre - half, centre + half)


def main(path):
    with open(path) as f:
        summary = json.load(f)
    entries = {e["name"]: e for e in summary["entries"]}
    pair = {}
    for p in summary["pairings"]:
        pair[(p["row"], p["col"])] = (p["winrate"], p["races"])
        pair[(p["col"], p["row"])] = (1 - p["winrate"], p["races"])
    runs = [e["name"] for e in summary["entries"] if e["hl"] == "policy" and e["name"] + "@center" in entries]
    if not runs:
        sys.exit(f"{path}: no run has controls; race the tournament with --controls")

    print("| run | vs @center [95% Wilson] | vs @random [95% Wilson] | winrate vs all entries "
          "| its @center vs all | its @random vs all |")
    print("|---|---|---|---|---|---|")
    pooled = {"center": [0.0, 0], "random": [0.0, 0]}
    above = {"center": 0, "random": 0}
    lb_above = {"center": 0, "random": 0}
    ub_below = {"center": 0, "random": 0}
    cells = []
    for r in runs:
        row = [r]
        for c in ("center", "random"):
            w, n = pair[(r, f"{r}@{c}")]
            lo, hi = wilson(w * n, n)
            row.append(f"{w:.3f} [{lo:.3f}, {hi:.3f}]")
            pooled[c][0] += w * n
            pooled[c][1] += n
            above[c] += w > 0.5
            lb_above[c] += lo > 0.5
            ub_below[c] += hi < 0.5
        trio = [entries[r]["winrate"], entries[f"{r}@center"]["winrate"], entries[f"{r}@random"]["winrate"]]
        cells.append(trio)
        row += [f"{x:.3f}" for x in trio]
        print("| " + " | ".join(row) + " |")

    print()
    for c in ("center", "random"):
        wins, n = pooled[c]
        lo, hi = wilson(wins, n)
        print(f"- pooled vs @{c}: {wins / n:.3f} [{lo:.3f}, {hi:.3f}] over {n} races; "
              f"{above[c]} of {len(runs)} runs above 0.5, {lb_above[c]} with the lower bound above 0.5, "
              f"{ub_below[c]} with the upper bound below 0.5")
    diffs = [t[0] - (t[1] + t[2]) / 2 for t in cells]
    if len(cells) < 2:  # one run: no spread between runs to split
        print(f"- run minus the mean of its controls (round-robin winrate): {diffs[0]:+.3f}")
        return
    print(f"- run minus the mean of its controls (round-robin winrate): {statistics.mean(diffs):+.3f} "
          f"+- {statistics.stdev(diffs):.3f} over {len(runs)} runs")
    run_wr = [t[0] for t in cells]
    print(f"- runs' round-robin winrates: {min(run_wr):.3f} to {max(run_wr):.3f} (std {statistics.stdev(run_wr):.3f})")
    # One-way decomposition over the 3 x len(runs) entries, grouped by run (sums of squares).
    allv = [x for t in cells for x in t]
    grand = statistics.mean(allv)
    between = sum(3 * (statistics.mean(t) - grand) ** 2 for t in cells)
    within = sum((x - statistics.mean(t)) ** 2 for t in cells for x in t)
    total = between + within
    print(f"- of the variance of round-robin winrate over the {len(allv)} run and control entries, "
          f"{100 * between / total:.1f} % lies between runs and {100 * within / total:.1f} % between a run's own "
          f"HL rules (trained, center, random)")


if __name__ == "__main__":
    if len(sys.argv) != 2:
        sys.exit(__doc__)
    main(sys.argv[1])
