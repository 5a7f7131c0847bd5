#!/usr/bin/env python3
"""Notebook 108's verdict: does the residual pilot out-fly the paper's against the autopilot on its line?

    experiments/scripts/residual_verdict.py KEEP_DIR
    experiments/scripts/residual_verdict.py --arms CONTROL TREATMENT KEEP_DIR

With --arms the same rule compares KEEP_DIR/TREATMENT with KEEP_DIR/CONTROL (notebook 109: ppo and
progress); the default arms are notebook 108's, ppo and residual.

KEEP_DIR holds ppo/ and residual/, each with the kept pieces of experiments/scripts/pilot_arm_piece.sh per
seed S: sS.json (the tournament against the tuned autopilot on its lanes and the run's controls,
experiments/scripts/pilot_seeds_table.py --keep) and sS_online.json (the tournament against the autopilot on
the run's racing line: its summary.json). Until all sixteen are in it says how many are, and
prints no number: the rule reads none before.

The rule (notebook 108, written before the runs): B_S = seed S's winrate against the autopilot on
its line; D_S = B_S(residual) - B_S(ppo); D = the mean over the eight seeds, its 95 % interval
D +- t(0.975, 7) sd(D_S) / sqrt(8). Out-flies: holds if the lower bound > 0; does not hold if the
upper bound < 0.05; otherwise cannot tell at this power. Adopted as the default if it holds, the
residual arm's mean against the autopilot on its lanes is at least the ppo arm's minus 0.02, and
its mean against its own @center at least 0.6. Reported beside it, per arm: the means and
t-intervals of the three winrates and the team's aircraft lost to the tube per race on the
lanes. Standard library only.
"""
import json
import math
import os
import sys

SEEDS = range(1, 9)
ARMS = ("ppo", "residual")
T_975_7 = 2.364624251592785  # Student's t, 0.975 quantile, 7 degrees of freedom


def read_json(path, seed):
    try:
        return json.load(open(path))
    except ValueError as e:
        sys.exit(f"{path}: unreadable ({e}); rerun experiments/scripts/pilot_arm_piece.sh for seed {seed}")


def load_arm(keep_dir, arm):
    """{seed: (lanes piece, online summary)} for the seeds whose two files are kept."""
    out = {}
    for s in SEEDS:
        lanes, online = (os.path.join(keep_dir, arm, f"s{s}{tail}.json") for tail in ("", "_online"))
        if not (os.path.exists(lanes) and os.path.exists(online)):
            continue
        a, b = read_json(lanes, s), read_json(online, s)
        if not all(k in a for k in ("ap", "c", "lost")):
            sys.exit(f"{lanes}: not a kept piece (pilot_seeds_table.py --keep writes them)")
        runs = [e for e in b.get("entries", []) if e.get("name") != "autopilot"]
        if len(runs) != 1 or len(b["entries"]) != 2:
            sys.exit(f"{online}: not a run against the autopilot alone (tournament --no-untrained --with-autopilot --autopilot-on-line)")
        out[s] = (a, runs[0]["winrate"])
    return out


def t_interval(xs):
    m = sum(xs) / len(xs)
    sd = math.sqrt(sum((x - m) ** 2 for x in xs) / (len(xs) - 1))
    h = T_975_7 * sd / math.sqrt(len(xs))
    return m, m - h, m + h


def main(argv):
    names = ARMS
    if len(argv) == 5 and argv[1] == "--arms" and argv[2] != argv[3]:
        names, argv = (argv[2], argv[3]), [argv[0], argv[4]]
    if len(argv) != 2 or not os.path.isdir(argv[1]):
        sys.exit("usage: experiments/scripts/residual_verdict.py [--arms CONTROL TREATMENT] KEEP_DIR "
                 "(with ppo/ and residual/, or CONTROL/ and TREATMENT/, of kept pieces)")
    control, treatment = names
    arms = {arm: load_arm(argv[1], arm) for arm in names}
    kept = sum(len(v) for v in arms.values())
    if kept < 2 * len(SEEDS):
        print(f"{kept} of the {2 * len(SEEDS)} pre-registered pieces kept; the rule reads none before all are in: "
              "no table and no verdict yet.")
        return
    print("| arm | vs the autopilot on its line [t 95 %] | on its lanes | vs its @center | lost to the tube per race (lanes) |")
    print("|---|---|---|---|---|")
    means = {}
    for arm in names:
        on_line = [arms[arm][s][1] for s in SEEDS]
        lanes = [arms[arm][s][0]["ap"] for s in SEEDS]
        center = [arms[arm][s][0]["c"] for s in SEEDS]
        tube = [arms[arm][s][0]["lost"]["tube"] for s in SEEDS]
        cells = [t_interval(v) for v in (on_line, lanes, center, tube)]
        means[arm] = [c[0] for c in cells]
        print(f"| {arm} | " + " | ".join(f"{m:.3f} [{lo:.3f}, {hi:.3f}]" for m, lo, hi in cells) + " |")
    d = [arms[treatment][s][1] - arms[control][s][1] for s in SEEDS]
    m, lo, hi = t_interval(d)
    word = "holds" if lo > 0 else "does not hold" if hi < 0.05 else "cannot tell at this power"
    print(f"\nD = {m:+.3f}, t 95 % [{lo:+.3f}, {hi:+.3f}] over {len(d)} seed pairs: the {treatment} pilot out-flies "
          f"the {control} one on the line: **{word}**")
    adopt = word == "holds" and means[treatment][1] >= means[control][1] - 0.02 and means[treatment][2] >= 0.6
    print(f"Adopted as the default: **{'yes' if adopt else 'no'}** (needs: holds; lanes >= {control}'s - 0.02; "
          f"@center >= 0.6)")


if __name__ == "__main__":
    main(sys.argv)
