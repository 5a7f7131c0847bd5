#!/usr/bin/env python3
"""Notebook 90's table: trained runs against the autopilot flying the race's line.

    experiments/scripts/on_line_table.py TOURNAMENT_DIR [TOURNAMENT_DIR ...]

Each TOURNAMENT_DIR is one seed's `tournament --runs RUN --no-untrained --with-autopilot
--autopilot-on-line` (its races.csv; the run is the entry that is not `autopilot`), in seed
order. Prints Markdown: per seed the run's winrate (a draw half a win) with its Wilson 95 %
interval, both teams' tube losses per race, the run's opponent collisions per race and its score
over the races neither team lost an aircraft in; then the mean over seeds with a percentile
bootstrap 95 % CI (10 000 resamples, random.Random(90), as notebook 90). Standard library.
"""
import csv
import os
import sys

sys.path.insert(0, os.path.dirname(os.path.abspath(__file__)))
from pilot_seeds_table import boot, head_to_head, wilson  # noqa: E402


def seed_row(folder):
    path = os.path.join(folder, "races.csv")
    if not os.path.isfile(path):
        sys.exit(f"{path}: no such file; give a tournament folder (tournament --with-autopilot --autopilot-on-line)")
    rows = list(csv.DictReader(open(path)))
    if not rows:
        sys.exit(f"{folder}/races.csv: no races; rerun the tournament")
    try:
        me = next(e for e in (rows[0]["blue"], rows[0]["red"]) if e != "autopilot")
        h = head_to_head(rows, me, "autopilot")
    except (KeyError, ValueError, StopIteration) as e:
        sys.exit(f"{path}: not a tournament's races.csv ({e!r}); rerun the tournament")
    return dict(w=h["w"] / h["n"], lo_hi=wilson(h["w"], h["n"]), tube=h["lost"]["tube"],
                ap_tube=h["opp_lost"]["tube"], coll=h["lost"]["collision"],
                clean=h["clean_w"] / max(h["clean_n"], 1), clean_n=h["clean_n"])


def main(folders):
    if not folders:
        sys.exit("usage: experiments/scripts/on_line_table.py TOURNAMENT_DIR [TOURNAMENT_DIR ...]")
    seeds = [seed_row(f) for f in folders]
    print("| seed | vs the autopilot on the line [Wilson 95 %] | tube losses per race: learned / autopilot "
          "| opponent collisions per race | clean races won (races) |")
    print("|---|---|---|---|---|")
    for i, s in enumerate(seeds, 1):
        print(f"| {i} | {s['w']:.3f} [{s['lo_hi'][0]:.3f}, {s['lo_hi'][1]:.3f}] | {s['tube']:.3f} / "
              f"{s['ap_tube']:.3f} | {s['coll']:.3f} | {s['clean']:.3f} ({s['clean_n']}) |")
    mean = lambda k: sum(s[k] for s in seeds) / len(seeds)  # noqa: E731
    lo, hi = boot([s["w"] for s in seeds], seed=90)
    clo, chi = boot([s["clean"] for s in seeds], seed=90)
    print(f"\nmean over seeds {mean('w'):.3f}, bootstrap 95 % [{lo:.3f}, {hi:.3f}] (10 000 resamples, "
          f"Random(90)); clean races {mean('clean'):.3f} [{clo:.3f}, {chi:.3f}]; tube losses per race "
          f"{mean('tube'):.3f} (learned) / {mean('ap_tube'):.3f} (autopilot)")


if __name__ == "__main__":
    main(sys.argv[1:])
