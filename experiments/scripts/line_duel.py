#!/usr/bin/env python3
"""A racing line against the start lanes (experiments/notebook/83): two `f16race race --policy autopilot`
folders on the same seed, the line flown by blue in the first (`--racing-line F,0`) and by red in
the second (`--racing-line 0,F`), so that every track is raced from both sides. Per track, the
line team's wins over the clean races (no aircraft of either team lost) and over all races; the
aircraft each team lost per race, by cause; the mean duration. Intervals: bootstrap 95 % over
tracks (10 000 resamples, random seed 83), the two races of a track resampled together.

    experiments/scripts/line_duel.py LINE_BLUE_DIR LINE_RED_DIR [--json FILE]

Standard library.
"""
import csv
import json
import random
import sys

RESAMPLES = 10000


def races(folder):
    try:
        with open(folder + "/races.csv", newline="") as f:
            rows = list(csv.DictReader(f))
    except OSError as e:
        raise SystemExit(f"{folder}/races.csv: {e.strerror}; run `f16race race --racing-line ...` into it first")
    if not rows:
        raise SystemExit(f"{folder}/races.csv: no races; run `f16race race` into it first")
    return rows


def race_view(row, line_team):
    """(clean, line won, line lost aircraft by cause, lanes lost by cause) of one race."""
    causes = row["terminations"].split(";")
    ts = len(causes) // 2
    teams = (causes[:ts], causes[ts:])
    lost = [{c: team.count(c) for c in set(team) if c != "none"} for team in teams]
    winner = int(float(row["winner_team"]))
    won = 0.5 if winner < 0 else float(winner == line_team)
    clean = not lost[0] and not lost[1]
    return clean, won, lost[line_team], lost[1 - line_team], float(row["duration_s"])


def tracks(blue_dir, red_dir):
    a, b = races(blue_dir), races(red_dir)
    if len(a) != len(b):
        raise SystemExit(f"{blue_dir} has {len(a)} races, {red_dir} {len(b)}: race both on the same seed and count")
    for ra, rb in zip(a, b):
        if ra["track_length_ft"] != rb["track_length_ft"]:
            raise SystemExit(f"race {ra['race']}: the two folders flew different tracks; use the same --seed")
    return [(race_view(ra, 0), race_view(rb, 1)) for ra, rb in zip(a, b)]


def summary(sample):
    """The measures of a list of tracks (each two race views)."""
    flat = [r for t in sample for r in t]
    clean = [r for r in flat if r[0]]
    n = len(flat)
    line_lost = sum(sum(r[2].values()) for r in flat) / n
    lanes_lost = sum(sum(r[3].values()) for r in flat) / n
    return {
        "clean_share": len(clean) / n,
        "clean_winrate": sum(r[1] for r in clean) / len(clean) if clean else float("nan"),
        "winrate": sum(r[1] for r in flat) / n,
        "line_lost_per_race": line_lost,
        "lanes_lost_per_race": lanes_lost,
        "lost_difference": line_lost - lanes_lost,
        "duration_s": sum(r[4] for r in flat) / n,
    }


def causes(flat, k):
    out = {}
    for r in flat:
        for c, m in r[k].items():
            out[c] = out.get(c, 0) + m
    return {c: m / len(flat) for c, m in sorted(out.items())}


def main(argv):
    if len(argv) not in (2, 4) or (len(argv) == 4 and argv[2] != "--json"):
        raise SystemExit("usage: experiments/scripts/line_duel.py LINE_BLUE_DIR LINE_RED_DIR [--json FILE]")
    ts = tracks(argv[0], argv[1])
    point = summary(ts)
    rng = random.Random(83)
    boots = [summary([ts[rng.randrange(len(ts))] for _ in ts]) for _ in range(RESAMPLES)]
    ci = {}
    for k in point:
        vals = sorted(b[k] for b in boots if b[k] == b[k])
        ci[k] = (vals[int(0.025 * len(vals))], vals[int(0.975 * len(vals)) - 1])
    flat = [r for t in ts for r in t]
    print(f"{len(ts)} tracks, {len(flat)} races")
    for k, v in point.items():
        print(f"{k}: {v:.3f} [{ci[k][0]:.3f}, {ci[k][1]:.3f}]")
    print("line team lost per race by cause:", json.dumps(causes(flat, 2)))
    print("lanes team lost per race by cause:", json.dumps(causes(flat, 3)))
    if len(argv) == 4:
        with open(argv[3], "w") as f:
            json.dump({"tracks": len(ts), "point": point, "ci95": ci, "line_lost_by_cause": causes(flat, 2),
                       "lanes_lost_by_cause": causes(flat, 3)}, f, indent=1)


if __name__ == "__main__":
    main(sys.argv[1:])
