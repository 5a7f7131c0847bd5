#!/usr/bin/env python3
"""The low level's learning curve against the tuned autopilot (notebook 81).

  ll_learning_curve.py --keep TOURNAMENT_DIR OUT.json   # a snapshot's small summary, to commit
  ll_learning_curve.py KEEP_DIR FINAL_DIR               # the curve and the pre-registered rule

--keep reads a `tournament --controls --with-autopilot` folder of one run (a pool snapshot made
by experiments/scripts/pool_snapshot_run.sh) and keeps, for RUN@center and RUN against `autopilot`: races,
wins, aircraft lost per race by cause, and the snapshot's env steps. The read mode takes the
kept files (sS_step_N.json) and the final low level's figure from FINAL_DIR/sS.json (the seed's
kept summary, `ll_center_vs_ap`, 3.5 M steps: the low level is frozen after).
"""
import csv
import glob
import json
import os
import random
import re
import sys

CAUSES = ["team_collision", "collision", "tube", "envelope", "altitude", "load", "turn_rate", "simulator"]
FINAL_STEPS = 3_500_000  # the default run's bilevel budget: the low level learns until here


def fail(msg):
    print(f"ll_learning_curve.py: {msg}", file=sys.stderr)
    sys.exit(2)


def load_json(path):
    """A kept file, or one line naming it when it is not JSON (a cut-off copy, a stray file)."""
    try:
        with open(path) as f:
            return json.load(f)
    except json.JSONDecodeError as e:
        fail(f"{path}: not a kept summary (JSON error at line {e.lineno}); keep it again with --keep")


def against_autopilot(rows, entry):
    """Races of `entry` against `autopilot`, from either side: wins and aircraft lost per race."""
    n = wins = 0
    lost = {c: 0 for c in CAUSES}
    for r in rows:
        if {r["blue"], r["red"]} != {entry, "autopilot"}:
            continue
        side = "blue" if r["blue"] == entry else "red"
        n += 1
        wins += r["winner"] == entry
        for c in CAUSES:
            lost[c] += int(r[f"{side}_out_{c}"])
    if n == 0:
        fail(f"no races of {entry} against autopilot (was it run with --controls --with-autopilot?)")
    return {"races": n, "wins": wins, "lost_per_race": {c: v / n for c, v in lost.items()}}


def keep(tdir, out):
    if not os.path.isfile(os.path.join(tdir, "done.txt")):
        fail(f"{tdir}: not a finished tournament (no done.txt)")
    with open(os.path.join(tdir, "races.csv")) as f:
        rows = list(csv.DictReader(f))
    runs = sorted({r["blue"] for r in rows} - {"autopilot"} - {e for e in {r["blue"] for r in rows} if "@" in e})
    if len(runs) != 1:
        fail(f"{tdir}: expected one run with its controls, found {runs}")
    run = runs[0]
    m = re.search(r"step_0*(\d+)", run)
    if not m:
        fail(f"{tdir}: entry {run} is not named step_<env steps> (experiments/scripts/pool_snapshot_run.sh)")
    kept = {"env_steps": int(m.group(1)), "center": against_autopilot(rows, run + "@center"),
            "run": against_autopilot(rows, run)}
    os.makedirs(os.path.dirname(os.path.abspath(out)), exist_ok=True)
    with open(out + ".tmp", "w") as f:
        json.dump(kept, f, indent=1)
    os.replace(out + ".tmp", out)


def slope(xs, ys):
    mx, my = sum(xs) / len(xs), sum(ys) / len(ys)
    return sum((x - mx) * (y - my) for x, y in zip(xs, ys)) / sum((x - mx) ** 2 for x in xs)


def boot(vals, n=10000):
    rng = random.Random(1)
    means = sorted(sum(rng.choice(vals) for _ in vals) / len(vals) for _ in range(n))
    return sum(vals) / len(vals), means[int(0.025 * n)], means[int(0.975 * n) - 1]


def read(keep_dir, final_dir):
    seeds = {}
    for p in glob.glob(os.path.join(keep_dir, "s*_step_*.json")):
        s = int(re.match(r"s(\d+)_", os.path.basename(p)).group(1))
        seeds.setdefault(s, []).append(load_json(p))
    if not seeds:
        fail(f"{keep_dir}: no sS_step_N.json files (run with --keep first)")
    slopes, firsts, finals, tube = [], [], [], {}
    print("| seed | @center vs autopilot at M steps (tube lost per race) | final | slope per M |")
    print("|---|---|---|---|")
    for s in sorted(seeds):
        pts = sorted(seeds[s], key=lambda d: d["env_steps"])
        final_path = os.path.join(final_dir, f"s{s}.json")
        if not os.path.isfile(final_path):
            fail(f"{final_path}: missing (the seed's kept summary)")
        final = load_json(final_path)["ll_center_vs_ap"]
        xs = [d["env_steps"] / 1e6 for d in pts] + [FINAL_STEPS / 1e6]
        ys = [d["center"]["wins"] / d["center"]["races"] for d in pts] + [final]
        b = slope(xs, ys)
        slopes.append(b)
        firsts.append(ys[0])
        finals.append(final)
        for i, d in enumerate(pts):
            tube.setdefault(i, []).append(d["center"]["lost_per_race"]["tube"])
        cells = ", ".join(f"{x:.2f}: {y:.3f} ({d['center']['lost_per_race']['tube']:.2f})" for x, y, d in zip(xs, ys, pts))
        print(f"| {s} | {cells} | {final:.3f} | {b:+.3f} |")
    n = len(slopes)
    m, lo, hi = boot(slopes)
    verdict = "still learning" if lo > 0 else ("declining" if hi < 0 else "flat")
    print(f"\nslope of @center vs autopilot per M steps, {n} seeds: mean {m:+.4f} bootstrap 95% [{lo:+.4f}, {hi:+.4f}]: {verdict}")
    d = [b - a for a, b in zip(firsts, finals)]
    m, lo, hi = boot(d)
    print(f"final minus first point: mean {m:+.4f} bootstrap 95% [{lo:+.4f}, {hi:+.4f}]")
    for i in sorted(tube):
        m, lo, hi = boot(tube[i])
        print(f"point {i + 1}: @center lost to the tube per race mean {m:.3f} [{lo:.3f}, {hi:.3f}]")
    m, lo, hi = boot(finals)
    print(f"final: @center vs autopilot mean {m:.3f} [{lo:.3f}, {hi:.3f}]")


def main():
    a = sys.argv[1:]
    if len(a) == 3 and a[0] == "--keep":
        keep(a[1], a[2])
    elif len(a) == 2 and not a[0].startswith("-"):
        read(a[0], a[1])
    else:
        fail("usage: ll_learning_curve.py --keep TOURNAMENT_DIR OUT.json | KEEP_DIR FINAL_DIR")


if __name__ == "__main__":
    main()
