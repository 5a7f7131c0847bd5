#!/usr/bin/env python3
"""Why a learned team wins or loses against the `autopilot` entry: airspeed and eliminations.

    experiments/scripts/autopilot_speed_table.py BINARY RUN_DIR [RUN_DIR ...] [--races N]

For each run, races it (blue) against AeroBench's waypoint autopilot (red) with
`BINARY replay --run RUN --opponent autopilot --seed K` for K = 1..N (default 16), and prints,
as Markdown, per run: blue's wins, the mean airspeed of each team over every sample of every
aircraft still racing, and the aircraft each team lost per race. Standard library only; the
replay folders go to a temporary directory and are removed.
"""
import csv
import os
import re
import subprocess
import sys
import tempfile


def team_stats(folder, agents):
    speeds = []
    for a in agents:
        with open(os.path.join(folder, f"replay_agent{a}.csv")) as f:
            speeds += [float(r["vt_ftps"]) for r in csv.DictReader(f)]
    return sum(speeds) / len(speeds)


def main(argv):
    races = 16
    if "--races" in argv:
        i = argv.index("--races")
        races = int(argv[i + 1])
        argv = argv[:i] + argv[i + 2:]
    if len(argv) < 3:
        sys.exit(__doc__)
    binary, runs = argv[1], argv[2:]
    print("| run | races | run wins | run airspeed ft/s | autopilot airspeed ft/s | run aircraft out / race | autopilot aircraft out / race |")
    print("|---|---|---|---|---|---|---|")
    with tempfile.TemporaryDirectory() as tmp:
        for run in runs:
            wins = 0
            blue_v, red_v, blue_out, red_out = [], [], 0, 0
            for k in range(1, races + 1):
                out = os.path.join(tmp, f"r{k}")
                text = subprocess.run([binary, "--threads", "1", "replay", "--run", run, "--opponent", "autopilot",
                                       "--seed", str(k), "--out", out], check=True, capture_output=True,
                                      text=True).stdout
                wins += "winner blue" in text
                outs = [int(m) for m in re.findall(r"aircraft (\d+) out at", text)]
                n_agent = len([f for f in os.listdir(out) if re.fullmatch(r"replay_agent\d+\.csv", f)])
                blue_out += sum(1 for a in outs if a < n_agent // 2)
                red_out += sum(1 for a in outs if a >= n_agent // 2)
                blue_v.append(team_stats(out, range(n_agent // 2)))
                red_v.append(team_stats(out, range(n_agent // 2, n_agent)))
            name = os.path.basename(os.path.normpath(run))
            print(f"| {name} | {races} | {wins} | {sum(blue_v) / races:.0f} | {sum(red_v) / races:.0f} | "
                  f"{blue_out / races:.2f} | {red_out / races:.2f} |")


if __name__ == "__main__":
    main(sys.argv)
