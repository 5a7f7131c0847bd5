#!/usr/bin/env python3
"""Which goal axis carries a high level's edge over its center line (notebook 100's rule).

    experiments/scripts/axis_edge.py edge TOURNAMENT_DIR ...      # each raced with --controls --axis-controls
    experiments/scripts/axis_edge.py losses TOURNAMENT_DIR ...    # what each team lost per race, by cause
    experiments/scripts/axis_edge.py inside REPLAY_DIR ...        # lateral bins on the inside of the turns ahead?
    experiments/scripts/axis_edge.py same-races NEW_DIR OLD_DIR   # the races both tournaments raced: same winners?

`edge` reads each tournament's summary.json: per run, its head-to-head winrate against RUN@center
and RUN@center_x / _y / _z (the run's own high level with that axis held on the middle bin) with
a Wilson 95 % interval, and the share of its decisions below / on / above the middle bin per axis;
then the head-to-heads pooled over the runs (their races taken as exchangeable) and the verdict
on height (the `up` axis):
  - "height carries most of the edge": pooled vs @center_z has its lower bound above 0.5 and its
    point above 0.5 + (vs @center - 0.5) / 2;
  - "height carries part of the edge": the lower bound above 0.5, the point not above that half;
  - "no height effect resolved": the lower bound at or below 0.5.
The along and right axes get the same words. `losses` reads races.csv: in each head-to-head of a
run with a control, each team's aircraft lost per race by cause, and the control's score in the
races where no aircraft was lost (a control that loses by pace, not by losses). `inside` reads
`replay` folders: per team, how often a decision's lateral bin points to the inside of the net
turn between the aircraft and its goal (the racing line; random bins: half). `same-races`
compares races.csv rows by (blue, red, race): how many of the races both hold had the same winner
and duration. Standard library only.
"""
import csv
import itertools
import json
import math
import os
import sys

sys.path.insert(0, os.path.dirname(os.path.abspath(__file__)))
from controls_table import wilson  # noqa: E402

AXES = {"x": "along", "y": "right", "z": "up"}
MIDDLE_BIN = 3  # of race.hl_bins 7 (the paper's): for replay_goals.csv written before it had middle_bin


def head_to_heads(summary):
    """{run: {rule: (wins, races)}} for every run entry against its own controls."""
    entries = {e["name"]: e for e in summary["entries"]}
    out = {}
    for p in summary["pairings"]:
        row, col = p["row"], p["col"]
        if entries[row]["hl"] != "policy" or not col.startswith(row + "@"):
            continue
        out.setdefault(row, {})[col[len(row) + 1:]] = (p["winrate"] * p["races"], p["races"])
    return out, entries


def fmt(wins, n):
    lo, hi = wilson(wins, n)
    return f"{wins / n:.3f} [{lo:.3f}, {hi:.3f}]"


def verdict(pooled, rule):
    wins, n = pooled[rule]
    lo, _ = wilson(wins, n)
    w = wins / n
    half = 0.5 + (pooled["center"][0] / pooled["center"][1] - 0.5) / 2
    if lo <= 0.5:
        return "no effect resolved"
    return "carries most of the edge" if w > half else "carries part of the edge"


def edge(dirs):
    rules = ["center", "center_x", "center_y", "center_z"]
    pooled = {r: [0.0, 0] for r in rules}
    print("| run | vs @center | vs @center_x (along) | vs @center_y (right) | vs @center_z (up) "
          "| along below/on/above | right | up |")
    print("|---|---|---|---|---|---|---|---|")
    for d in dirs:
        summary = json.load(open(os.path.join(d, "summary.json")))
        h2h, entries = head_to_heads(summary)
        for run, by_rule in sorted(h2h.items()):
            missing = [r for r in rules if r not in by_rule]
            if missing:
                sys.exit(f"{d}: {run} has no pairing with @{', @'.join(missing)}; race it with --controls --axis-controls")
            for r in rules:
                pooled[r][0] += by_rule[r][0]
                pooled[r][1] += by_rule[r][1]
            g = entries[run]["goal_choices"]
            shares = [" / ".join(f"{v:.2f}" for v in g[AXES[a]]) for a in "xyz"]
            print(f"| {run} ({os.path.basename(os.path.normpath(d))}) | "
                  + " | ".join(fmt(*by_rule[r]) for r in rules) + " | " + " | ".join(shares) + " |")
    if pooled["center"][1] == 0:
        sys.exit("no run with controls in " + " ".join(dirs))
    print("| pooled | " + " | ".join(fmt(*pooled[r]) for r in rules) + " | | | |")
    print()
    for a in "xyz":
        print(f"{AXES[a]}: {verdict(pooled, 'center_' + a)}")


CAUSES = ["collision", "team_collision", "tube", "envelope"]


def losses(dirs):
    """Aircraft lost per race by cause in each head-to-head of a run with its controls, for the
    run's team and the control's: does a control lose by its losses, or by its pace?"""
    print("| run | control | races | run lost: " + ", ".join(CAUSES) + " | control lost: same | control's clean races won |")
    print("|---|---|---|---|---|---|")
    for d in dirs:
        with open(os.path.join(d, "races.csv")) as f:
            races = list(csv.DictReader(f))
        pairs = {}
        for r in races:
            a, b = r["blue"], r["red"]
            run, ctl = (a, b) if b.startswith(a + "@") else (b, a) if a.startswith(b + "@") else (None, None)
            if run is None:
                continue
            side = {"blue": a, "red": b}
            p = pairs.setdefault((run, ctl), {"n": 0, run: [0] * len(CAUSES), ctl: [0] * len(CAUSES), "clean": 0, "clean_won": 0.0})
            p["n"] += 1
            out = 0
            for team, who in side.items():
                for k, c in enumerate(CAUSES):
                    p[who][k] += int(r[f"{team}_out_{c}"])
                out += int(r[f"{team}_terminated"])
            if out == 0:
                p["clean"] += 1
                p["clean_won"] += 1.0 if r["winner"] == ctl else 0.5 if r["winner"] == "draw" else 0.0
        for (run, ctl), p in sorted(pairs.items()):
            n = p["n"]
            cells = [", ".join(f"{x / n:.3f}" for x in p[who]) for who in (run, ctl)]
            clean = f"{p['clean_won'] / p['clean']:.3f} ({p['clean']})" if p["clean"] else "-"
            print(f"| {run} | {ctl[len(run) + 1:]} | {n} | {cells[0]} | {cells[1]} | {clean} |")


def turns(folder):
    """Arc length (chords between waypoints) and the signed sine of the horizontal turn at each
    waypoint of a replay's track (+: to the right)."""
    with open(os.path.join(folder, "replay_track.csv")) as f:
        wps = [(float(r["pn_ft"]), float(r["pe_ft"]), float(r["alt_ft"])) for r in csv.DictReader(f)]
    s = [0.0]
    for a, b in zip(wps, wps[1:]):
        s.append(s[-1] + math.dist(a, b))
    turn = [0.0] * len(wps)
    for k in range(1, len(wps) - 1):
        d1 = (wps[k][0] - wps[k - 1][0], wps[k][1] - wps[k - 1][1])
        d2 = (wps[k + 1][0] - wps[k][0], wps[k + 1][1] - wps[k][1])
        turn[k] = (d1[0] * d2[1] - d1[1] * d2[0]) / (math.hypot(*d1) * math.hypot(*d2))
    return s, turn


def inside(folders, min_turn=0.05):
    """Per team of `replay` folders: how often a decision's lateral bin (off the middle) points
    to the inside of the net turn between the aircraft and its goal (net sine above min_turn).
    A high level that takes the racing line picks the inside; random bins do half the time."""
    got = {}
    for d in folders:
        s, turn = turns(d)
        at = {}
        for a in itertools.count():
            path = os.path.join(d, f"replay_agent{a}.csv")
            if not os.path.exists(path):
                break
            with open(path) as f:
                for r in csv.DictReader(f):
                    at[(a, round(float(r["t_s"]), 2))] = float(r["s_ft"])
        with open(os.path.join(d, "replay_goals.csv")) as f:
            goals = list(csv.DictReader(f))
        for g in goals:
            s_a = at.get((int(g["agent"]), round(float(g["t_s"]), 2)))
            if s_a is None:
                continue
            net = sum(turn[k] for k in range(1, len(s) - 1) if s_a < s[k] <= float(g["s_ft"]))
            b, mid = int(g["bin_y"]), int(float(g.get("middle_bin") or MIDDLE_BIN))
            c = got.setdefault(int(g["team"]), [0, 0])
            if abs(net) < min_turn or b == mid:
                continue
            c[0] += (b > mid) == (net > 0)
            c[1] += 1
    for team, (n_in, n) in sorted(got.items()):
        print(f"team {team}: lateral bin on the inside of the turns ahead in {n_in} of {n} decisions"
              + (f" ({n_in / n:.3f})" if n else ""))
    return got


def rows(path):
    with open(os.path.join(path, "races.csv")) as f:
        return {(r["blue"], r["red"], int(r["race"])): r for r in csv.DictReader(f)}


def same_races(new, old):
    a, b = rows(new), rows(old)
    common = sorted(set(a) & set(b))
    same = sum(a[k]["winner"] == b[k]["winner"] and a[k]["duration_s"] == b[k]["duration_s"] for k in common)
    print(f"{same} of {len(common)} common races have the same winner and duration")
    return bool(common) and same == len(common)  # True: every common race the same (and some in common)


def checked(dirs, needed):
    """The folders, each holding `needed`; else one line naming the first that does not."""
    for d in dirs:
        if not os.path.isfile(os.path.join(d, needed)):
            sys.exit(f"{d}: no {needed} in it; pass the folders a tournament wrote (--out)")
    return dirs


def main(argv):
    if len(argv) >= 3 and argv[1] == "edge":
        edge(checked(argv[2:], "summary.json"))
        return 0
    if len(argv) >= 3 and argv[1] == "inside":
        inside(argv[2:])
        return 0
    if len(argv) >= 3 and argv[1] == "losses":
        losses(checked(argv[2:], "races.csv"))
        return 0
    if len(argv) == 4 and argv[1] == "same-races":
        return 0 if same_races(argv[2], argv[3]) else 1
    print(__doc__, file=sys.stderr)
    return 2


if __name__ == "__main__":
    sys.exit(main(sys.argv))
