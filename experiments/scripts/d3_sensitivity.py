#!/usr/bin/env python3
"""Notebook 112's keeper and verdict: is the Fig. 3 study's ES+D3 result sensitive to the C51
support's spacing, to the paper's Huber reading of the loss, or to the decisions each phase
switch drops?

    experiments/scripts/d3_sensitivity.py --keep-piece PIECE KEEP_DIR
    experiments/scripts/d3_sensitivity.py KEEP_DIR

With --keep-piece, PIECE is one seed's folder (experiments/scripts/d3_sensitivity_piece.sh): its
round robin of six runs (PIECE/tour/pairings.csv) and each run's env steps per ES update and
training wall time go to KEEP_DIR/sS.json, small enough to commit.

The verdict, per sensitivity arm (notebook 112's rule): the per-seed difference
D_S = w(arm, its ES+D2) - w(d3, d2) (d3_fine and d3_huber against d2; d3_keep against d2_keep),
its mean and 95 % t-interval over the seeds: "D3 gains" if the interval lies above 0, "D3 loses"
if below, else "not resolved"; beside it, deciding nothing for ES+D3, w(arm, its ES+D2) with its
t-interval. train.keep_hl_decisions is kept for a main-job A/B if w(d2_keep, d2)'s t-interval lies
above 0.5, removed otherwise. Fewer seeds than the rule names: only how many are kept. Standard
library only.
"""
import csv
import os
import re
import statistics
import sys

sys.path.insert(0, os.path.dirname(os.path.abspath(__file__)))
import kept_json  # noqa: E402

PLANNED = 8
ARMS = ("d2", "d3", "d3_fine", "d3_huber", "d2_keep", "d3_keep")
# Two-sided 95 % t quantiles by degrees of freedom (any table; e.g. NIST/SEMATECH e-Handbook 1.3.6.7.2).
T975 = {1: 12.706, 2: 4.303, 3: 3.182, 4: 2.776, 5: 2.571, 6: 2.447, 7: 2.365, 8: 2.306, 9: 2.262, 10: 2.228,
        11: 2.201}


def pairings(piece):
    path = os.path.join(piece, "tour", "pairings.csv")
    if not os.path.exists(path):
        sys.exit(f"{path}: missing; the piece's round robin has not finished (rerun d3_sensitivity_piece.sh)")
    w = {}
    with open(path) as f:
        for r in csv.DictReader(f):
            w[f"{r['row_entry']}|{r['column_entry']}"] = [float(r["winrate"]), int(r["races"])]
    missing = [f"{a}|{b}" for a in ARMS for b in ARMS if a != b and f"{a}|{b}" not in w]
    if missing:
        sys.exit(f"{path}: no pairing {missing[0]}; not a piece of notebook 112")
    return w


def run_cost(run):
    """(mean env steps per ES update after the first, training wall seconds) from RUN/metrics.csv."""
    path = os.path.join(run, "metrics.csv")
    with open(path) as f:
        rows = [r for r in csv.DictReader(f) if r.get("env_steps")]
    if len(rows) < 3:
        sys.exit(f"{path}: fewer than three updates; the run has not finished")
    steps = [int(r["env_steps"]) for r in rows]
    per_update = [b - a for a, b in zip(steps[1:], steps[2:])]
    return statistics.mean(per_update), float(rows[-1]["wall_s"])


def keep_piece(piece, keep_dir):
    m = re.fullmatch(r"s(\d+)", os.path.basename(os.path.normpath(piece)))
    if not m:
        sys.exit(f"{piece}: not a piece folder (d3_sensitivity_piece.sh names them sSEED)")
    runs = {}
    for arm in ARMS:
        per_update, wall = run_cost(os.path.join(piece, arm))
        runs[arm] = dict(env_steps_per_es_update=per_update, wall_s=wall)
    kept_json.write(os.path.join(keep_dir, f"s{m.group(1)}.json"),
                    dict(seed=int(m.group(1)), pairings=pairings(piece), runs=runs, **kept_json.provenance()))


def load(keep_dir):
    return kept_json.load_pieces(keep_dir, ("seed", "pairings", "runs"), "d3_sensitivity.py")


def t_interval(xs):
    m = statistics.mean(xs)
    h = T975[len(xs) - 1] * statistics.stdev(xs) / len(xs) ** 0.5
    return m, m - h, m + h


def w(p, a, b):
    return p["pairings"][f"{a}|{b}"][0]


def verdict(pieces):
    lines = ["| arm | against | w(arm, against) [95 % t] | D vs w(d3, d2) [95 % t] | reading |", "|---|---|---|---|---|"]
    base = [w(p, "d3", "d2") for p in pieces]
    m, lo, hi = t_interval(base)
    lines.append(f"| d3 (the study's) | d2 | {m:.3f} [{lo:.3f}, {hi:.3f}] | | |")
    for arm, against in (("d3_fine", "d2"), ("d3_huber", "d2"), ("d3_keep", "d2_keep")):
        x = [w(p, arm, against) for p in pieces]
        d = [a - b for a, b in zip(x, base)]
        mx, lx, hx = t_interval(x)
        md, ld, hd = t_interval(d)
        reading = "D3 gains" if ld > 0 else ("D3 loses" if hd < 0 else "not resolved")
        lines.append(f"| {arm} | {against} | {mx:.3f} [{lx:.3f}, {hx:.3f}] | {md:+.3f} [{ld:+.3f}, {hd:+.3f}] | "
                     f"**{reading}** |")
    k = [w(p, "d2_keep", "d2") for p in pieces]
    mk, lk, hk = t_interval(k)
    lines.append(f"\nw(d2_keep, d2) = {mk:.3f} [{lk:.3f}, {hk:.3f}]: train.keep_hl_decisions "
                 + ("**kept for a main-job A/B**" if lk > 0.5 else "**removed**"))
    lines.append("\n| arm | env steps per ES update (mean over seeds) | the run's own training wall s, tail members not counted (mean) |\n|---|---|---|")
    for arm in ARMS:
        s = statistics.mean(p["runs"][arm]["env_steps_per_es_update"] for p in pieces)
        t = statistics.mean(p["runs"][arm]["wall_s"] for p in pieces)
        lines.append(f"| {arm} | {s:.0f} | {t:.0f} |")
    return "\n".join(lines)


def main(argv):
    if argv[1:2] == ["--keep-piece"]:
        if len(argv) != 4:
            sys.exit("usage: d3_sensitivity.py --keep-piece PIECE KEEP_DIR")
        return keep_piece(argv[2], argv[3])
    if len(argv) != 2:
        sys.exit("usage: d3_sensitivity.py KEEP_DIR")
    pieces = load(argv[1])
    if len(pieces) < PLANNED:
        print(f"{len(pieces)} of the {PLANNED} pre-registered seeds kept; notebook 112 reads none before all are in.")
        return
    print(verdict(pieces))


if __name__ == "__main__":
    main(sys.argv)
