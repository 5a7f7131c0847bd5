#!/usr/bin/env python3
"""Notebook 106's rule: does the long race make the high level matter more, and does it become
the default?

    experiments/scripts/long_race_verdict.py SHORT_DIR LONG_DIR

Each folder holds an arm's kept seeds (`experiments/scripts/seed_arm.sh` summaries, sS.json) or its raw
`sS/` and `t_sS/` folders, as `pilot_seeds_table.py` reads them. Per run: e = winrate against its
own @center, a = against the tuned autopilot, f = the share of its tournament's races that end at
the finish line. D = mean e (long) - mean e (short) with a bootstrap 95 % CI (seeds resampled
within each arm, pilot_seeds_table.difference_ci). Verdict: "holds" if the CI lies above 0,
"does not hold" if it lies below 0.05 (the study's δ), else "cannot tell at this power". Adopt the
long tracks when it holds, the long arm's mean f >= 0.95 and the CI of its mean a lies above 0.5.
Prints Markdown. Standard library.
"""
import os
import sys

sys.path.insert(0, os.path.dirname(os.path.abspath(__file__)))
import pilot_seeds_table as table  # noqa: E402

DELTA = 0.05
FINISH_BAR = 0.95


def arm(folder):
    seeds = table.finished_seeds(folder)
    if not seeds:
        sys.exit(f"{folder}: no finished seed (sS.json, or t_sS/done.txt); run experiments/scripts/seed_arm.sh first")
    return [table.seed_row(folder, s, show=False) for s in seeds]


def mean_row(name, per, key, fmt="{:.3f}"):
    xs = [p[key] for p in per if p.get(key) is not None]
    if not xs:
        return f"| {name} | n/a | |"
    m, (lo, hi) = table.mean_ci(xs)
    return f"| {name} | {fmt.format(m)} | [{fmt.format(lo)}, {fmt.format(hi)}] |"


def verdict(lo, hi):
    return "holds" if lo > 0 else ("does not hold" if hi < DELTA else "cannot tell at this power")


def main(argv):
    if len(argv) != 3 or not all(os.path.isdir(a) for a in argv[1:]):
        sys.exit("usage: experiments/scripts/long_race_verdict.py SHORT_DIR LONG_DIR (folders of kept seeds)")
    short, long_ = arm(argv[1]), arm(argv[2])
    for name, per in (("short", short), ("long", long_)):
        missing = [p for p in per if p.get("finish") is None]
        if missing:
            sys.exit(f"{argv[1] if name == 'short' else argv[2]}: {len(missing)} kept seeds lack `finish` "
                     "(kept before pilot_seeds_table.py kept it); keep them again from their tournaments")
    print(f"seeds: short {len(short)}, long {len(long_)}\n")
    print("| measure, mean over seeds | short | 95 % CI | long | 95 % CI |\n|---|---|---|---|---|")
    for key, what, fmt in (("c", "e: vs own @center", "{:.3f}"), ("r", "vs own @random", "{:.3f}"),
                           ("ap", "a: vs the tuned autopilot", "{:.3f}"), ("finish", "f: races at the finish line",
                                                                           "{:.3f}"),
                           ("center_median_s", "median race vs @center, s", "{:.1f}"),
                           ("blocks_vs_center", "blocks per race beyond @center's", "{:+.3f}")):
        a = mean_row(what, short, key, fmt).split("|")
        b = mean_row(what, long_, key, fmt).split("|")
        print(f"|{a[1]}|{a[2]}|{a[3]}|{b[2]}|{b[3]}|")
    d, lo, hi = table.difference_ci([p["c"] for p in long_], [p["c"] for p in short])
    v = verdict(lo, hi)
    print(f"\nD = e(long) - e(short) = {d:+.3f}, bootstrap 95 % [{lo:+.3f}, {hi:+.3f}]: "
          f"the long race makes the high level matter more: **{v}**")
    f_long = sum(p["finish"] for p in long_) / len(long_)
    _, (a_lo, _) = table.mean_ci([p["ap"] for p in long_])
    keeps = f_long >= FINISH_BAR and a_lo > 0.5
    print(f"long arm's low level: f {f_long:.3f} (bar {FINISH_BAR}), a's CI lower end {a_lo:.3f} (bar 0.5): "
          + ("keeps issue 50's conditions" if keeps else "does not keep issue 50's conditions"))
    adopt = v == "holds" and keeps
    print("\n**Adopt the long tracks in configs/default.yaml**" if adopt else
          "\n**The default stays** (notebook 106's rule)")
    return 0


if __name__ == "__main__":
    sys.exit(main(sys.argv))
