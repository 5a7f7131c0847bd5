#!/usr/bin/python3
"""RaceEnv.step from Python against the C++ `f16race bench env`, in one run.

Both time the same thing on the same races: n_env races of the default config (seed 1) flown by
the scripted pilot, only the step call timed (Python: argument checks, the C++ step, the result
tuple and info dict), median over repeats after one warm-up run. Rounds alternate Python and
C++ so that a load change on the machine hits both.

    PYTHONPATH=build/python /usr/bin/python3 examples/python/bench_env.py [--envs 1024 --team-size 4]
"""
import argparse
import json
import os
import statistics
import subprocess
import sys
import time

import numpy as np

import f16race


def python_rate(envs, team_size, steps, repeats):
    """Env steps per second of RaceEnv.step (the C++ bench's loop, from Python)."""
    env = f16race.RaceEnv(overrides={"race.n_env": envs, "race.team_size": team_size})
    actions = np.zeros((envs, 2 * team_size, 3), np.float32)
    bins = np.full((envs, 2 * team_size, 3), env.hl_bins // 2, np.int64)
    rates = []
    for rep in range(repeats + 1):
        spent = 0.0
        for _ in range(steps):
            env.set_hl_actions(bins)
            env.scripted_actions(out=actions)
            t0 = time.perf_counter()
            env.step(actions)
            spent += time.perf_counter() - t0
        if rep > 0:  # the first run warms up, as in the C++ bench
            rates.append(steps / spent)
    return statistics.median(rates)


def cpp_rate(binary, envs, team_size, steps, repeats, threads):
    out = subprocess.run([binary, "bench", "env", "--envs", str(envs), "--team-size", str(team_size), "--steps",
                          str(steps), "--repeats", str(repeats), "--threads", str(threads), "--json"],
                         check=True, capture_output=True, text=True).stdout
    return json.loads(out.strip().splitlines()[-1])["env_steps_per_s"]


def main():
    root = os.path.dirname(os.path.dirname(os.path.dirname(os.path.abspath(__file__))))
    p = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    p.add_argument("--envs", type=int, default=1024)
    p.add_argument("--team-size", type=int, default=4)
    p.add_argument("--steps", type=int, default=50, help="LL steps per timed run (the C++ default)")
    p.add_argument("--repeats", type=int, default=5, help="timed runs per measurement, median reported")
    p.add_argument("--threads", type=int, nargs="+", default=[1, os.cpu_count() or 1])
    p.add_argument("--rounds", type=int, default=2, help="Python / C++ measurement pairs per thread count")
    p.add_argument("--f16race", default=os.path.join(root, "build", "f16race"), help="the C++ executable")
    a = p.parse_args()
    if not os.access(a.f16race, os.X_OK):
        sys.exit(f"bench_env.py: {a.f16race}: no f16race executable (build it, or pass --f16race PATH)")
    print(f"bench env from Python: {a.envs} envs x {2 * a.team_size} aircraft, {a.steps} LL steps per run, "
          f"median of {a.repeats}, {a.rounds} rounds")
    print(f"{'threads':>8} {'python env_steps/s':>19} {'C++ env_steps/s':>16} {'python/C++':>11}")
    worst = None
    for t in sorted(set(a.threads)):
        f16race.set_num_threads(t)
        py, cpp = [], []
        for _ in range(a.rounds):
            py.append(python_rate(a.envs, a.team_size, a.steps, a.repeats))
            cpp.append(cpp_rate(a.f16race, a.envs, a.team_size, a.steps, a.repeats, t))
        ratio = statistics.median(py) / statistics.median(cpp)
        worst = ratio if worst is None else min(worst, ratio)
        print(f"{t:8d} {statistics.median(py):19.1f} {statistics.median(cpp):16.1f} {ratio:11.3f}", flush=True)
        print(f"{'':8} rounds: python {', '.join(f'{x:.1f}' for x in py)}; C++ {', '.join(f'{x:.1f}' for x in cpp)}")
    print(f"lowest python/C++ ratio: {worst:.3f} (target >= 0.8)")


if __name__ == "__main__":
    main()
