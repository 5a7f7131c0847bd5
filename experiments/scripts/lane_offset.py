#!/usr/bin/env python3
"""How far a learned low level holds itself from its lane: the measure of notebook 73 ("Where the
tube losses come from") and the mechanism notebook 74 reports. RUN@center (every goal on the
center line, so the lane is the center line) races AeroBench's autopilot in the replays of seeds
1..N; over the run's aircraft, and each race after its first 5 s while the aircraft is still in
it, the mean offset from the center line, right and up, / the local tube radius.

    experiments/scripts/lane_offset.py RUN [--races N]                    # prints right, up and their size
    experiments/scripts/lane_offset.py --add KEEP_JSON RUN [--races N]    # adds "center_offset" to a kept seed
    experiments/scripts/lane_offset.py RUN --goal-shift-up X              # the replays' goals moved up by X R (notebook 97)

N defaults to 12. F16RACE names the binary (default build/f16race). Standard library.
"""
import csv
import json
import math
import os
import re
import subprocess
import sys
import tempfile

sys.path.insert(0, os.path.dirname(os.path.abspath(__file__)))
import kept_json  # noqa: E402

SETTLE_S = 5.0  # the start offsets are random: the first seconds say nothing about a held offset
FATE = re.compile(r"^\| (\d+) \| (blue|red) \| (.*?) \|", re.M)
OUT_AT = re.compile(r"out at ([\d.]+) s")


def blue_aircraft(replay_md):
    """{agent: time it was taken out, or inf} for the blue team (the run) of one replay."""
    out = {}
    for agent, team, fate in FATE.findall(replay_md):  # the fates table comes first: later tables
        if team == "blue" and int(agent) not in out:  # (blocks) cannot overwrite a fate
            m = OUT_AT.search(fate)
            out[int(agent)] = float(m.group(1)) if m else math.inf
    return out


def race_sums(folder):
    """Sums of right/R and up/R and the number of samples of one replay folder's blue aircraft."""
    right = up = 0.0
    n = 0
    for agent, out_s in blue_aircraft(open(os.path.join(folder, "replay.md")).read()).items():
        for row in csv.DictReader(open(os.path.join(folder, f"replay_agent{agent}.csv"))):
            t = float(row["t_s"])
            if t < SETTLE_S or t > out_s:
                continue
            r = float(row["radius_ft"])
            right += float(row["lateral_ft"]) / r
            up += float(row["vertical_ft"]) / r
            n += 1
    return right, up, n


def center_offset(run, races, extra=()):
    binary = os.environ.get("F16RACE", os.path.join(os.path.dirname(__file__), "..", "..", "build", "f16race"))
    right = up = 0.0
    n = 0
    with tempfile.TemporaryDirectory() as tmp:
        for seed in range(1, races + 1):
            out = os.path.join(tmp, f"r{seed}")
            done = subprocess.run([binary, "--threads", "1", "replay", "--run", run + "@center", "--opponent",
                                   "autopilot", "--seed", str(seed), "--out", out, *extra], capture_output=True, text=True)
            if done.returncode != 0:
                sys.exit(f"{run}: replay --seed {seed} failed: {done.stderr.strip()}")
            r, u, k = race_sums(out)
            right, up, n = right + r, up + u, n + k
    if n == 0:
        sys.exit(f"{run}: no sample after {SETTLE_S} s in {races} replays")
    right, up = right / n, up / n
    return {"right": right, "up": up, "size": math.hypot(right, up), "races": races, "samples": n}


def main():
    args = sys.argv[1:]
    races = 12
    extra = []
    if len(args) >= 3 and args[-2] == "--goal-shift-up":  # the replays' goals moved (notebook 97)
        extra = ["--set", f"race.goal_shift_up_frac={args[-1]}"]
        args = args[:-2]
    if len(args) >= 2 and args[-2] == "--races":
        if not args[-1].isdigit() or int(args[-1]) < 1:
            sys.exit(f"--races {args[-1]}: give a whole number of races, at least 1")
        races = int(args[-1])
        args = args[:-2]
    if len(args) == 3 and args[0] == "--add":
        kept, run = args[1], args[2]
        if not os.path.isfile(kept):
            sys.exit(f"{kept}: no kept seed file; run pilot_seeds_table.py --keep first")
        try:
            m = json.load(open(kept))
        except json.JSONDecodeError as e:
            sys.exit(f"{kept}: not a kept seed file ({e}); write it again with pilot_seeds_table.py --keep")
        m["center_offset"] = center_offset(run, races)
        kept_json.write(kept, m)
        return
    if len(args) != 1:
        sys.exit("usage: experiments/scripts/lane_offset.py [--add KEEP_JSON] RUN [--races N] [--goal-shift-up X]")
    o = center_offset(args[0], races, extra)
    print(f"{args[0]}@center vs autopilot, {races} races: offset right {o['right']:+.3f} R, up {o['up']:+.3f} R, "
          f"size {o['size']:.3f} R ({o['samples']} samples)")


if __name__ == "__main__":
    main()
