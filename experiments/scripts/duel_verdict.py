#!/usr/bin/env python3
"""Notebook 107's verdict: does ES+D3 beat ES+D2 head to head when both have 16 times the budget?

    experiments/scripts/duel_verdict.py KEEP_DIR
    experiments/scripts/duel_verdict.py --keep-piece STUDY KEEP_DIR

With --keep-piece, STUDY is one piece (experiments/scripts/duel_piece.sh): es_d2_sS and es_d3_sS of one seed
at 8 s on one frozen pilot, their round robin (dt8/tournament/pairings.csv) and each run's
controls (dt8/controls/RUN); w_S = es_d3_sS's winrate against es_d2_sS, both runs' controls, the
CPU and the binary go to KEEP_DIR/sS.json, small enough to commit.

The verdict: M = mean of w_S over the kept seeds; its 95 % interval by bootstrap over seeds
(10 000 replicates, Random("107:es_d3:es_d2"), percentiles 2.5 and 97.5). ES+D3 beats ES+D2:
holds if lo > 0.5; does not hold if hi < 0.55 (the study's delta; "reversed" when hi < 0.5);
otherwise cannot tell at this power; with fewer than the eight seeds the rule names, only how
many are kept (no number is shown before all are in). Reported beside it, deciding nothing: each
variant's mean
winrate against its own center line and blocks per race minus its center line's. Standard
library only.
"""
import csv
import os
import random
import re
import sys

sys.path.insert(0, os.path.dirname(os.path.abspath(__file__)))
import kept_json  # noqa: E402
from study_verdicts import all_of, beats, read_controls  # noqa: E402

PLANNED = 8  # seeds in notebook 107's rule
REPS = 10000


def head_to_head(study, seed):
    """(winrate of es_d3_sS against es_d2_sS, races) from the piece's round robin."""
    path = os.path.join(study, "dt8", "tournament", "pairings.csv")
    if not os.path.exists(path):
        sys.exit(f"{path}: missing; the piece's round robin has not finished (rerun duel_piece.sh)")
    d3, d2 = f"es_d3_s{seed}", f"es_d2_s{seed}"
    with open(path) as f:
        for r in csv.DictReader(f):
            pair = (r["row_entry"], r["column_entry"])
            if pair in ((d3, d2), (d2, d3)):
                x = float(r["winrate"])
                return (x if pair[0] == d3 else 1.0 - x), int(r["races"])
    sys.exit(f"{path}: no pairing of {d3} and {d2}; not a piece of seed {seed}")


def keep_piece(study, keep_dir):
    m = re.search(r"_s(\d+)$", os.path.basename(os.path.normpath(study)))
    if not m:
        sys.exit(f"{study}: not a piece folder (duel_piece.sh names them xMULT_sSEED)")
    seed = int(m.group(1))
    w, races = head_to_head(study, seed)
    controls = {}
    for v in ("es_d2", "es_d3"):
        run = f"{v}_s{seed}"
        controls[run] = read_controls(study, 8, run)
        if controls[run] is None:
            sys.exit(f"{study}/dt8/controls/{run}: no done.txt; race the run's controls first")
    kept_json.write(os.path.join(keep_dir, f"s{seed}.json"),
                    dict(seed=seed, d3_vs_d2=w, races=races, controls=controls, **kept_json.provenance()))


def load(keep_dir):
    return kept_json.load_pieces(keep_dir, ("seed", "d3_vs_d2", "controls"), "duel_verdict.py")


def verdict(pieces):
    """M, its interval and the rule's word, read as study_verdicts reads "u beats v"."""
    w = [p["d3_vs_d2"] for p in pieces]
    r = random.Random("107:es_d3:es_d2")
    reps = [sum(w[r.randrange(len(w))] for _ in w) / len(w) for _ in range(REPS)]
    reading, lo, hi = beats(reps)
    word = all_of([reading]) + (" (reversed)" if reading == "no, reversed" else "")
    return sum(w) / len(w), lo, hi, word


def main(argv):
    if argv[1:2] == ["--keep-piece"]:
        if len(argv) != 4:
            sys.exit("usage: duel_verdict.py --keep-piece STUDY KEEP_DIR")
        return keep_piece(argv[2], argv[3])
    if len(argv) != 2:
        sys.exit("usage: duel_verdict.py KEEP_DIR")
    pieces = load(argv[1])
    if len(pieces) < PLANNED:
        # The rule reads no seed before all are in: no winrate is printed, so none can be seen early.
        print(f"{len(pieces)} of the {PLANNED} pre-registered seeds kept; notebook 107 reads none before all are in: "
              "no table and no verdict yet.")
        return
    print("| seed | ES+D3 vs ES+D2 | races | es_d2 vs @center | es_d3 vs @center | es_d2 blocks | es_d3 blocks | CPU |")
    print("|---|---|---|---|---|---|---|---|")
    for p in pieces:
        c2, c3 = p["controls"][f"es_d2_s{p['seed']}"], p["controls"][f"es_d3_s{p['seed']}"]
        print(f"| {p['seed']} | {p['d3_vs_d2']:.3f} | {p.get('races', '')} | {c2['vs_center']:.3f} | {c3['vs_center']:.3f} | "
              f"{c2['block_diff_sum'] / c2['races']:+.2f} | {c3['block_diff_sum'] / c3['races']:+.2f} | {p.get('cpu', '')} |")
    m, lo, hi, word = verdict(pieces)
    print(f"\nM(es_d3, es_d2) = {m:.3f}, bootstrap 95 % [{lo:.3f}, {hi:.3f}] over {len(pieces)} seeds: "
          f"ES+D3 beats ES+D2 at this budget: **{word}**")


if __name__ == "__main__":
    main(sys.argv)
