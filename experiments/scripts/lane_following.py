#!/usr/bin/env python3
"""Does the low level fly the lane its high-level goal names?

Reads `f16race replay` folders and, for every HL decision of a team, compares the goal's offset
in the tube cross-section (replay_goals.csv: lateral_ft, vertical_ft) with the aircraft's own
offset DELAY seconds later (replay_agent<k>.csv). Prints, per axis, the correlation and the
least-squares slope (1 = the aircraft sits in the chosen lane, 0 = goals are ignored). Use a
team with varied goals, e.g. `f16race replay --run RUN@random --opponent RUN@center`.

usage: experiments/scripts/lane_following.py [--team 0] [--delay 6] REPLAY_DIR...
"""
import argparse
import csv
import math
import os


def fit(xs, ys):
    n = len(xs)
    mx, my = sum(xs) / n, sum(ys) / n
    sxx = sum((x - mx) ** 2 for x in xs)
    syy = sum((y - my) ** 2 for y in ys)
    sxy = sum((x - mx) * (y - my) for x, y in zip(xs, ys))
    return sxy / math.sqrt(sxx * syy), sxy / sxx


def main():
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("--team", type=int, default=0, help="0 blue, 1 red")
    ap.add_argument("--delay", type=float, default=6.0, help="seconds after the decision")
    ap.add_argument("dirs", nargs="+")
    a = ap.parse_args()
    pairs = {"lateral_ft": ([], []), "vertical_ft": ([], [])}
    for d in a.dirs:
        tracks = {}
        with open(os.path.join(d, "replay_goals.csv")) as f:
            goals = [g for g in csv.DictReader(f) if int(g["team"]) == a.team]
        for g in goals:
            k = int(g["agent"])
            if k not in tracks:
                with open(os.path.join(d, f"replay_agent{k}.csv")) as f:
                    tracks[k] = list(csv.DictReader(f))
            t = float(g["t_s"]) + a.delay
            later = [r for r in tracks[k] if abs(float(r["t_s"]) - t) < 0.041]
            if not later:
                continue  # the aircraft was out or the race over by then
            for axis, (xs, ys) in pairs.items():
                xs.append(float(g[axis]))
                ys.append(float(later[0][axis]))
    for axis, (xs, ys) in pairs.items():
        if len(xs) < 3:
            print(f"{axis}: too few decisions ({len(xs)})")
            continue
        r, slope = fit(xs, ys)
        print(f"{axis}: {len(xs)} decisions, correlation {r:+.3f}, slope {slope:+.3f} (aircraft offset {a.delay:g} s later vs goal offset)")


if __name__ == "__main__":
    main()
