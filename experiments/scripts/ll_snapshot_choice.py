#!/usr/bin/env python3
"""Would choosing the low level among a run's last snapshots, on tracks of its own, pay on other
tracks? The measure of notebook 104. Per run, the first self-play pool snapshot at or past the
low level's freeze (train.total_env_steps x (1 - train.hl_tail_share): it holds the final ll.pt)
and the K - 1 snapshots before it are each raced as SNAPSHOT@center against AeroBench's autopilot
(`tournament --controls --with-autopilot`; every goal on the center line, so only the low level
plays) on two sets of tracks: --choose-seed, where the best is chosen, and --judge-seed, where the
choice and the final low level are compared.

    experiments/scripts/ll_snapshot_choice.py RUN ... --out CSV [--k 4] [--races 384] [--jobs 2]
    experiments/scripts/ll_snapshot_choice.py --report CSV       # the verdict of notebook 104's rule

Resumable: rows already in CSV are not raced again. F16RACE names the binary (default
build/f16race); each tournament runs on one thread. Standard library.
"""
import argparse
import concurrent.futures
import csv
import filecmp
import os
import re
import shutil
import subprocess
import sys
import tempfile

sys.path.insert(0, os.path.dirname(os.path.abspath(__file__)))
from pilot_seeds_table import boot  # noqa: E402

HERE = os.path.dirname(os.path.dirname(os.path.dirname(os.path.abspath(__file__))))
FIELDS = ["run", "step", "final", "tracks_seed", "wins", "races"]


def config_value(run, key):
    """A number of RUN/config.yaml's train section, read without a YAML library."""
    text = open(os.path.join(run, "config.yaml")).read()
    m = re.search(r"^train:\n((?:[ \t].*\n|\n)*)", text, re.M)
    v = re.search(r"^\s+" + key + r":\s*([0-9.eE+-]+)", m.group(1), re.M) if m else None
    if not v:
        sys.exit(f"{run}/config.yaml: no train.{key}")
    return float(v.group(1))


def candidates(run, k):
    """The final low level's snapshot and the k - 1 before it, oldest first."""
    freeze = config_value(run, "total_env_steps") * (1.0 - config_value(run, "hl_tail_share"))
    steps = sorted(int(d[5:]) for d in os.listdir(os.path.join(run, "pool")) if re.fullmatch(r"step_\d+", d))
    past = [s for s in steps if s >= freeze]
    if not past:
        sys.exit(f"{run}/pool: no snapshot at or past the freeze ({freeze:.0f} steps); the run is not done")
    final = past[0]
    before = [s for s in steps if s < final][-(k - 1):] if k > 1 else []
    if len(before) < k - 1:
        sys.exit(f"{run}/pool: only {len(before)} snapshots before {final}; give a smaller --k")
    latest = open(os.path.join(run, "checkpoint", "LATEST")).read().strip()
    if not filecmp.cmp(os.path.join(run, "pool", f"step_{final:010d}", "ll.pt"),
                       os.path.join(run, "checkpoint", latest, "ll.pt"), shallow=False):
        sys.exit(f"{run}/pool/step_{final:010d}/ll.pt: not the run's final low level")
    return before + [final], final


def race(run, step, seed, races, work):
    """Wins and races of SNAPSHOT@center against the autopilot on the tracks of `seed`."""
    bin_ = os.environ.get("F16RACE", os.path.join(HERE, "build", "f16race"))
    snap = os.path.join(work, f"{abs(hash(run))}_{step}_{seed}")
    shutil.rmtree(snap, ignore_errors=True)
    subprocess.run([os.path.join(HERE, "experiments", "scripts", "pool_snapshot_run.sh"), run, f"step_{step:010d}", snap],
                   check=True, stdout=subprocess.DEVNULL)
    out = snap + "_t"
    subprocess.run([bin_, "--threads", "1", "tournament", "--runs", snap, "--no-untrained", "--with-autopilot",
                    "--controls", "--races", str(races), "--seed", str(seed), "--out", out],
                   check=True, stdout=subprocess.DEVNULL)
    name = os.path.basename(snap)
    with open(os.path.join(out, "pairings.csv")) as f:
        for row in csv.DictReader(f):
            if row["row_entry"] == name + "@center" and row["column_entry"] == "autopilot":
                wins = round(float(row["winrate"]) * int(row["races"]) * 2) / 2
                shutil.rmtree(snap)
                shutil.rmtree(out)
                return wins, int(row["races"])
    sys.exit(f"{out}/pairings.csv: no {name}@center against autopilot")


def measure(args):
    done = set()
    if os.path.exists(args.out):
        with open(args.out) as f:
            done = {(r["run"], int(r["step"]), int(r["tracks_seed"])) for r in csv.DictReader(f)}
    todo = []
    for run in args.runs:
        steps, final = candidates(run, args.k)
        for step in steps:
            for seed in (args.choose_seed, args.judge_seed):
                if (run, step, seed) not in done:
                    todo.append((run, step, final, seed))
    work = tempfile.mkdtemp(prefix="ll_choice_")
    new = not os.path.exists(args.out)
    with open(args.out, "a", newline="") as f, concurrent.futures.ThreadPoolExecutor(args.jobs) as pool:
        w = csv.writer(f)
        if new:
            w.writerow(FIELDS)
        futures = {pool.submit(race, run, step, seed, args.races, work): (run, step, final, seed)
                   for run, step, final, seed in todo}
        for fut in concurrent.futures.as_completed(futures):
            run, step, final, seed = futures[fut]
            wins, races = fut.result()
            w.writerow([run, step, int(step == final), seed, wins, races])
            f.flush()
            print(f"{run} step {step} tracks {seed}: {wins / races:.3f}", flush=True)
    shutil.rmtree(work, ignore_errors=True)


def bootstrap_mean(xs):
    """The mean and pilot_seeds_table.boot's 95 % CI of it (10 000 resamples, seed 1)."""
    return (sum(xs) / len(xs),) + boot(xs)


def report(path, choose_seed, judge_seed):
    rates = {}  # run -> step -> seed -> winrate
    finals = {}
    with open(path) as f:
        for r in csv.DictReader(f):
            rates.setdefault(r["run"], {}).setdefault(int(r["step"]), {})[int(r["tracks_seed"])] = (
                float(r["wins"]) / int(r["races"]))
            if r["final"] == "1":
                finals[r["run"]] = int(r["step"])
    gains, spreads, lines = [], [], []
    for run, steps in sorted(rates.items()):
        if run not in finals or any(len(v) < 2 for v in steps.values()):
            continue
        pick = max(steps, key=lambda s: (steps[s][choose_seed], s))  # ties: the later snapshot
        gain = steps[pick][judge_seed] - steps[finals[run]][judge_seed]
        judged = [v[judge_seed] for v in steps.values()]
        gains.append(gain)
        spreads.append(max(judged) - min(judged))
        cells = " ".join(f"{steps[s][choose_seed]:.3f}/{steps[s][judge_seed]:.3f}" for s in sorted(steps))
        lines.append(f"| {run} | {cells} | {pick} | {gain:+.3f} |")
    print("| run | each snapshot, oldest first: chosen-on / judged-on tracks | chosen | gain on judged tracks |")
    print("|---|---|---|---|")
    print("\n".join(lines))
    if gains:
        m, lo, hi = bootstrap_mean(gains)
        verdict = "pays" if lo > 0 else ("costs" if hi < 0 else "does not pay")
        print(f"\ngain of the chosen low level over the final one, {len(gains)} runs: mean {m:+.3f} "
              f"bootstrap 95% [{lo:+.4f}, {hi:+.4f}]: selection {verdict}")
        m, lo, hi = bootstrap_mean(spreads)
        print(f"spread of the snapshots on the judged tracks (max - min): mean {m:.3f} [{lo:.3f}, {hi:.3f}]")


def main():
    p = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    p.add_argument("runs", nargs="*")
    p.add_argument("--out")
    p.add_argument("--report")
    p.add_argument("--k", type=int, default=4)
    p.add_argument("--races", type=int, default=384)
    p.add_argument("--jobs", type=int, default=2)
    p.add_argument("--choose-seed", type=int, default=7)
    p.add_argument("--judge-seed", type=int, default=11)
    a = p.parse_args()
    if a.report:
        report(a.report, a.choose_seed, a.judge_seed)
    elif a.runs and a.out:
        measure(a)
    else:
        p.error("give RUN ... --out CSV, or --report CSV")


if __name__ == "__main__":
    main()
