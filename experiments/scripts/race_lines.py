#!/usr/bin/env python3
"""Where a clean race is won (issue 49): in replays of RUN against AeroBench's autopilot (seeds
1..N), over the races in which no aircraft was taken out, each team's mean airspeed, its progress
along the track's center line (ds/dt) and that progress per foot flown (ds / path length; above 1
on the inside of bends), every aircraft after the race's first 5 s; and the lead at the end: the
run's leading aircraft's distance along the track minus the autopilot's (the team of the leader
wins). Both teams fly at the envelope's cap, so what is left to win with is a line. The cap is a
Mach number, so an aircraft's airspeed at the cap falls with its altitude: each team's mean
altitude, height above the center line and Mach say whether an airspeed difference is a
difference in how close to the cap a pilot holds or in where it flies; and below the cap, the
throttle flown (after the Mach governor), the share of steps in which the governor, not the
policy, set it, the engine's power and the angle of attack say whether it is throttle or drag.

    experiments/scripts/race_lines.py RUN [RUN ...] [--races N] [--save FILE] [--control FILE]

One line per run and team, then the run's team minus the autopilot's, averaged over the runs with
a bootstrap 95 % interval over runs (10 000 resamples, random seed 49). N defaults to 12.
--save writes each run's differences (run minus autopilot) to FILE as JSON; --control reads such a
file of another arm and adds, per measure, this arm's mean minus the control's with a bootstrap
95 % interval (the runs resampled within each arm): an A/B's mechanism over seeds.
F16RACE names the binary (default build/f16race). Standard library.
"""
import csv
import json
import math
import os
import random
import re
import subprocess
import sys
import tempfile

SETTLE_S = 5.0  # the start's random offsets and speeds say nothing about a line
FATE = re.compile(r"^\| (\d+) \| (blue|red) \| (.*?) \|", re.M)
MEASURES = ("airspeed_ftps", "along_ftps", "along_per_path", "alt_ft", "above_line_ft", "mach", "throttle",
            "governor_share", "power_pct", "alpha_deg", "lead_ft")
N_LINE = len(MEASURES) - 1  # the per-aircraft measures; the lead is per race


def fates(replay_md):
    """{agent: (team, fate)} from the replay's first table (later tables cannot overwrite it)."""
    out = {}
    for agent, team, fate in FATE.findall(replay_md):
        out.setdefault(int(agent), (team, fate))
    return out


def mach(vt_ftps, alt_ft):
    """The simulator's Mach number (lib/dynamics/engine.hpp air_data, AeroBench's adc.py)."""
    temp_rankine = 390.0 if alt_ft >= 35000.0 else 519.0 * (1.0 - 0.703e-5 * alt_ft)
    return vt_ftps / math.sqrt(1.4 * 1716.3 * temp_rankine)


def aircraft_line(csv_path):
    """(mean airspeed, ds/dt, ds/path, altitude, height above the center line, Mach, throttle flown,
    share of rows whose throttle the governor cut, power, angle of attack in degrees) of one
    aircraft after SETTLE_S, or None with too few rows; and its distance along the track at the end."""
    every = list(csv.DictReader(open(csv_path)))
    if every and "throttle" not in every[0]:
        sys.exit(f"{csv_path}: no throttle columns; replay with a build from 630ce59 on (F16RACE names it)")
    rows = [r for r in every if float(r["t_s"]) >= SETTLE_S]
    s_end = float(every[-1]["s_ft"])
    if len(rows) < 2:
        return None, s_end
    point = [(float(r["pn_ft"]), float(r["pe_ft"]), float(r["alt_ft"])) for r in rows]
    path = sum(math.dist(p, q) for p, q in zip(point, point[1:]))
    ds = float(rows[-1]["s_ft"]) - float(rows[0]["s_ft"])
    dt = float(rows[-1]["t_s"]) - float(rows[0]["t_s"])
    if path <= 0.0 or dt <= 0.0:
        return None, s_end
    n = len(rows)
    airspeed = sum(float(r["vt_ftps"]) for r in rows) / n
    alt = sum(p[2] for p in point) / n
    above = sum(float(r["vertical_ft"]) for r in rows) / n
    m = sum(mach(float(r["vt_ftps"]), float(r["alt_ft"])) for r in rows) / n
    throttle = sum(float(r["throttle"]) for r in rows) / n
    governed = sum(float(r["throttle"]) < float(r["throttle_cmd"]) - 1e-9 for r in rows) / n
    power = sum(float(r["power_pct"]) for r in rows) / n
    alpha = sum(math.degrees(float(r["alpha_rad"])) for r in rows) / n
    return (airspeed, ds / dt, ds / path, alt, above, m, throttle, governed, power, alpha), s_end


def run_lines(binary, run, races):
    """{team: [sums of MEASURES..., aircraft]} over the clean races of `races` replays, and each clean
    race's lead at the end (ft)."""
    sums = {"blue": [0.0] * N_LINE + [0], "red": [0.0] * N_LINE + [0]}
    leads = []
    with tempfile.TemporaryDirectory() as tmp:
        for seed in range(1, races + 1):
            out = os.path.join(tmp, f"r{seed}")
            done = subprocess.run([binary, "--threads", "1", "replay", "--run", run, "--opponent", "autopilot",
                                   "--seed", str(seed), "--out", out], capture_output=True, text=True)
            if done.returncode != 0:
                sys.exit(f"{run}: replay --seed {seed} failed: {done.stderr.strip()}")
            f = fates(open(os.path.join(out, "replay.md")).read())
            if any("out at" in fate for _, fate in f.values()):
                continue
            best = {"blue": -math.inf, "red": -math.inf}
            for agent, (team, _) in f.items():
                line, s_end = aircraft_line(os.path.join(out, f"replay_agent{agent}.csv"))
                best[team] = max(best[team], s_end)
                if line is None:
                    continue
                s = sums[team]
                for k, v in enumerate(line):
                    s[k] += v
                s[N_LINE] += 1
            leads.append(best["blue"] - best["red"])
    return sums, leads


def bootstrap_mean(values, resamples=10000, seed=49):
    rng = random.Random(seed)
    means = sorted(sum(rng.choice(values) for _ in values) / len(values) for _ in range(resamples))
    return means[int(0.025 * resamples)], means[int(0.975 * resamples) - 1]


def bootstrap_difference(treatment, control, resamples=10000, seed=49):
    """95 % interval of mean(treatment) - mean(control), the runs resampled within each arm."""
    rng = random.Random(seed)
    d = sorted(sum(rng.choice(treatment) for _ in treatment) / len(treatment) -
               sum(rng.choice(control) for _ in control) / len(control) for _ in range(resamples))
    return d[int(0.025 * resamples)], d[int(0.975 * resamples) - 1]


def take_option(args, name):
    """The value after `name` in args (both removed), or None when absent."""
    if name not in args:
        return None
    k = args.index(name)
    if k + 1 >= len(args) or args[k + 1].startswith("--"):
        sys.exit(f"{name}: give a value after it")
    value = args[k + 1]
    del args[k:k + 2]
    return value


def read_control(path):
    """{measure: [per-run values]} of a file written by --save."""
    try:
        runs = json.load(open(path))["runs"]
        return {m: [r[m] for r in runs.values()] for m in MEASURES}
    except (OSError, ValueError, KeyError, TypeError) as e:
        sys.exit(f"--control {path}: not a file written by race_lines.py --save ({e.__class__.__name__}: {e})")


def compare(diffs, control):
    for k, name in enumerate(MEASURES):
        values, base = [d[k] for d in diffs], control[name]
        if not values or not base:
            return
        lo, hi = bootstrap_difference(values, base)
        print(f"arm minus control, {name}, {len(values)} against {len(base)} runs: "
              f"{sum(values) / len(values):+.4f} - {sum(base) / len(base):+.4f} = "
              f"{sum(values) / len(values) - sum(base) / len(base):+.4f} bootstrap 95% [{lo:+.4f}, {hi:+.4f}]")


def main():
    args = sys.argv[1:]
    races = take_option(args, "--races") or "12"
    if not races.isdigit() or int(races) < 1:
        sys.exit(f"--races {races}: give a whole number of races, at least 1")
    races = int(races)
    save, control_path = take_option(args, "--save"), take_option(args, "--control")
    control = read_control(control_path) if control_path else None
    if not args:
        sys.exit("usage: experiments/scripts/race_lines.py RUN [RUN ...] [--races N] [--save FILE] [--control FILE]")
    binary = os.environ.get("F16RACE", os.path.join(os.path.dirname(__file__), "..", "..", "build", "f16race"))
    if not os.path.isfile(binary):
        sys.exit(f"F16RACE={binary}: no such binary; give the path of an f16race build")
    binary = os.path.abspath(binary)  # a bare name would be looked up on PATH
    diffs, names = [], []
    for run in args:
        sums, leads = run_lines(binary, run, races)
        clean = len(leads)
        if sums["blue"][N_LINE] == 0 or sums["red"][N_LINE] == 0:
            print(f"{run}: no clean race in {races} replays")
            continue
        mean = {t: [s[k] / s[N_LINE] for k in range(N_LINE)] for t, s in sums.items()}
        for team, who in (("blue", "run"), ("red", "autopilot")):
            m = mean[team]
            print(f"{run} {who:9} {clean:2} clean races: airspeed {m[0]:6.1f} ft/s, along the track {m[1]:6.1f} ft/s, "
                  f"per foot flown {m[2]:.4f}, altitude {m[3]:7.0f} ft, {m[4]:+5.0f} ft above the line, "
                  f"Mach {m[5]:.4f}, throttle {m[6]:.3f} (governor's {m[7]:.2f} of steps), power {m[8]:5.1f} %, "
                  f"alpha {m[9]:.2f} deg")
        lead = sum(leads) / clean
        sd = math.sqrt(sum((x - lead) ** 2 for x in leads) / clean)
        print(f"{run} lead at the end {lead:+7.1f} ft (sd {sd:.1f}), ahead in {sum(x > 0 for x in leads)} of {clean}")
        diffs.append([mean["blue"][k] - mean["red"][k] for k in range(N_LINE)] + [lead])
        names.append(run)
    if len(diffs) > 1:
        for k, name in enumerate(MEASURES):
            values = [d[k] for d in diffs]
            lo, hi = bootstrap_mean(values)
            print(f"run minus autopilot, {name}, {len(values)} runs: mean {sum(values) / len(values):+.4f} "
                  f"bootstrap 95% [{lo:+.4f}, {hi:+.4f}]")
    if control:
        compare(diffs, control)
    if save:
        tmp = save + ".tmp"
        with open(tmp, "w") as f:
            json.dump({"races": races, "runs": {n: dict(zip(MEASURES, d)) for n, d in zip(names, diffs)}}, f, indent=1)
        os.replace(tmp, save)


if __name__ == "__main__":
    main()
