#!/usr/bin/env python3
"""Notebook 66's pilot rule, as notebook 72 applies it: choose the Fig. 3 study's two pilots and
keep their low levels in the repository.

    experiments/scripts/choose_pilots.py KEEP_DIR RUNS_DIR OUT_DIR [NAMES]

KEEP_DIR holds the candidate seeds' kept summaries (sS.json, experiments/scripts/seed_arm.sh), RUNS_DIR their
run folders (sS). Seeds are ranked by the Wilson 95 % lower bound of their winrate against the
tuned autopilot (`ap_lo`); in that order each is raced on the long tracks (`tournament --runs sS
--no-untrained --with-autopilot --controls --races 256 --tracks configs/long.yaml`, into
RUNS_DIR/pilotcheck_sS) until two finish at least 95 % of all their races at the finish line.
NAMES (default AB) are the pilots to fill, in order: the first seed that passes becomes
pilot NAMES[0], the next NAMES[1]; notebook 72 fills B only (pilot A survived). OUT_DIR/pilot_X
receives what
`train.ll_from` reads (config.yaml, checkpoint/LATEST, and that checkpoint's ll.pt and
meta.yaml), and OUT_DIR/pilotcheck_sS the check's pairings.csv and summary.md. F16RACE names the binary
(default build/f16race); F16RACE_THREADS the threads (default 2). Standard library only.
"""
import csv
import json
import os
import shutil
import subprocess
import sys

FINISH_SHARE = 0.95  # notebook 66: a pilot must finish this share of long races
END_FINISH_LINE = 1  # races.csv end_reason


def ranked(keep):
    seeds = []
    for name in os.listdir(keep):
        if name.startswith("s") and name.endswith(".json"):
            m = json.load(open(os.path.join(keep, name)))
            seeds.append((m["ap_lo"], int(name[1:-5])))
    return [s for _, s in sorted(seeds, key=lambda x: (-x[0], x[1]))]


def check(binary, threads, runs, seed):
    """The long-race check's folder and the share of its races ended at the finish line."""
    out = os.path.join(runs, f"pilotcheck_s{seed}")
    if not os.path.exists(os.path.join(out, "done.txt")):
        here = os.path.dirname(os.path.dirname(os.path.dirname(os.path.abspath(__file__))))
        subprocess.run([binary, "--threads", threads, "tournament", "--runs", os.path.join(runs, f"s{seed}"),
                        "--no-untrained", "--with-autopilot", "--controls", "--races", "256",
                        "--tracks", "configs/long.yaml", "--out", out], check=True, cwd=here)
    rows = list(csv.DictReader(open(os.path.join(out, "races.csv"))))
    return out, sum(int(r["end_reason"]) == END_FINISH_LINE for r in rows) / len(rows)


def keep_pilot(run, dest):
    """What train.ll_from reads, and nothing more (no HL, no optimiser-only files)."""
    latest = open(os.path.join(run, "checkpoint", "LATEST")).read().strip()
    tmp = dest + ".tmp"
    shutil.rmtree(tmp, ignore_errors=True)
    os.makedirs(os.path.join(tmp, "checkpoint", latest))
    shutil.copy(os.path.join(run, "config.yaml"), tmp)
    shutil.copy(os.path.join(run, "checkpoint", "LATEST"), os.path.join(tmp, "checkpoint"))
    for f in ("ll.pt", "meta.yaml"):
        shutil.copy(os.path.join(run, "checkpoint", latest, f), os.path.join(tmp, "checkpoint", latest))
    shutil.rmtree(dest, ignore_errors=True)
    os.replace(tmp, dest)


def main(argv):
    if len(argv) not in (4, 5) or (len(argv) == 5 and not set(argv[4]) <= set("AB")):
        sys.exit("usage: experiments/scripts/choose_pilots.py KEEP_DIR RUNS_DIR OUT_DIR [NAMES, e.g. AB or B]")
    keep, runs, out = (os.path.abspath(a) for a in argv[1:4])
    names = argv[4] if len(argv) == 5 else "AB"
    here = os.path.dirname(os.path.dirname(os.path.dirname(os.path.abspath(__file__))))
    binary = os.path.abspath(os.environ.get("F16RACE", os.path.join(here, "build", "f16race")))
    threads = os.environ.get("F16RACE_THREADS", "2")
    order = ranked(keep)
    if not order:
        sys.exit(f"{keep}: no kept seed (sS.json)")
    chosen = []
    for seed in order:
        folder, share = check(binary, threads, runs, seed)
        passed = share >= FINISH_SHARE
        print(f"s{seed}: {share:.3f} of long races at the finish line: {'passes' if passed else 'fails'}")
        dest = os.path.join(out, f"pilotcheck_s{seed}")
        os.makedirs(dest, exist_ok=True)
        for f in ("pairings.csv", "summary.md"):
            shutil.copy(os.path.join(folder, f), dest)
        if passed:
            name = names[len(chosen)]
            chosen.append(seed)
            keep_pilot(os.path.join(runs, f"s{seed}"), os.path.join(out, "pilot_" + name))
            print(f"pilot {name} = s{seed}")
        if len(chosen) == len(names):
            return
    sys.exit(f"only {len(chosen)} of {len(order)} seeds pass the long-race check; {len(names)} pilots wanted")


if __name__ == "__main__":
    main(sys.argv)
