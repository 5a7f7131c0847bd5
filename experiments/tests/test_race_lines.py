#!/usr/bin/env python3
"""experiments/scripts/race_lines.py on replays whose answer is known. A stand-in binary writes, per seed T,
one blue and one red aircraft flying straight north, 0.2 s apart: blue at 600 ft/s with s
growing 606 ft/s (1.01 per foot), red at 630 ft/s with s growing 630 ft/s; before 5 s both sit
still with wild speeds (rows the measure skips). Seed 2 loses blue at 9 s (an unclean race: all
of it skipped). So over 3 races: 2 clean, blue 600 / 606 / 1.01, red 630 / 630 / 1.0, and red
leads at the end (12 s) by 7 x (630 - 606) = 168 ft. Blue flies at 9 000 ft, 1 000 ft below the
center line, red on it at 10 000 ft: Mach 0.5551 and 0.5851 (the simulator's air data). Blue's
policy commands throttle 0.3 and flies it (power 20 %, alpha 2 deg); red commands 1.0 and the
governor lets 0.2 through in every other row (power 14 %, alpha 3 deg)."""
import json
import os
import subprocess
import sys
import tempfile

SCRIPT = sys.argv[1]
FAKE = r'''#!/usr/bin/env python3
import math, os, sys
a = sys.argv
out = a[a.index("--out") + 1]
seed = int(a[a.index("--seed") + 1])
assert a[a.index("--opponent") + 1] == "autopilot"
os.makedirs(out)
blue = "out at 9.00 s (tube)" if seed == 2 else "in the race at the end"
open(os.path.join(out, "replay.md"), "w").write(
    "| aircraft | team | fate | HL decisions |\n|---|---|---|---|\n"
    f"| 0 | blue | {blue} | 2 |\n| 1 | red | in the race at the end | 0 |\n")
def write(agent, v, ds, alt, above, cmd, flown, power, alpha_deg):
    with open(os.path.join(out, f"replay_agent{agent}.csv"), "w") as f:
        f.write("t_s,s_ft,pn_ft,pe_ft,alt_ft,vertical_ft,vt_ftps,throttle_cmd,throttle,power_pct,alpha_rad\n")
        for k in range(61):
            t = round(0.2 * k, 6)
            fly = max(0.0, t - 5.0)
            th = flown if k % 2 == 0 else cmd
            f.write(f"{t},{ds * fly},{v * fly},0,{alt},{above},{v if t >= 5 else 9999},{cmd},{th},{power},"
                    f"{math.radians(alpha_deg)}\n")
write(0, 600.0, 606.0, 9000, -1000, 0.3, 0.3, 20.0, 2.0)
write(1, 630.0, 630.0, 10000, 0, 1.0, 0.2, 14.0, 3.0)
'''

with tempfile.TemporaryDirectory() as tmp:
    fake = os.path.join(tmp, "f16race")
    open(fake, "w").write(FAKE)
    os.chmod(fake, 0o755)
    env = dict(os.environ, F16RACE=fake)
    r = subprocess.run([sys.executable, SCRIPT, "runs/x", "runs/y", "--races", "3"], capture_output=True, text=True,
                       env=env)
    assert r.returncode == 0, r.stderr
    out = r.stdout
    assert "runs/x run        2 clean races: airspeed  600.0 ft/s, along the track  606.0 ft/s, per foot flown 1.0100, " \
        "altitude    9000 ft, -1000 ft above the line, Mach 0.5551, throttle 0.300 (governor's 0.00 of steps), " \
        "power  20.0 %, alpha 2.00 deg" in out, out
    assert "runs/y autopilot  2 clean races: airspeed  630.0 ft/s, along the track  630.0 ft/s, per foot flown 1.0000, " \
        "altitude   10000 ft,    +0 ft above the line, Mach 0.5851, throttle 0.600 (governor's 0.50 of steps), " \
        "power  14.0 %, alpha 3.00 deg" in out, out
    assert "airspeed_ftps, 2 runs: mean -30.0000 bootstrap 95% [-30.0000, -30.0000]" in out, out
    assert "along_ftps, 2 runs: mean -24.0000" in out, out
    assert "along_per_path, 2 runs: mean +0.0100" in out, out
    assert "alt_ft, 2 runs: mean -1000.0000" in out, out
    assert "above_line_ft, 2 runs: mean -1000.0000" in out, out
    assert "mach, 2 runs: mean -0.0300" in out, out
    assert "throttle, 2 runs: mean -0.3000" in out, out
    assert "governor_share, 2 runs: mean -0.5000" in out, out
    assert "power_pct, 2 runs: mean +6.0000" in out, out
    assert "alpha_deg, 2 runs: mean -1.0000" in out, out
    assert "runs/x lead at the end  -168.0 ft (sd 0.0), ahead in 0 of 2" in out, out
    assert "lead_ft, 2 runs: mean -168.0000" in out, out
    # --save keeps each run's differences; --control compares an arm with a saved one.
    saved = os.path.join(tmp, "lines.json")
    r = subprocess.run([sys.executable, SCRIPT, "runs/x", "runs/y", "--races", "3", "--save", saved],
                       capture_output=True, text=True, env=env)
    assert r.returncode == 0, r.stderr
    kept = json.load(open(saved))
    assert kept["races"] == 3 and sorted(kept["runs"]) == ["runs/x", "runs/y"], kept
    assert abs(kept["runs"]["runs/y"]["mach"] + 0.0300) < 5e-5 and kept["runs"]["runs/x"]["lead_ft"] == -168.0, kept
    control = os.path.join(tmp, "control.json")
    measures = dict(kept["runs"]["runs/x"])
    json.dump({"runs": {"a": dict(measures, mach=-0.02), "b": dict(measures, mach=-0.01)}}, open(control, "w"))
    r = subprocess.run([sys.executable, SCRIPT, "runs/x", "runs/y", "--races", "3", "--control", control],
                       capture_output=True, text=True, env=env)
    assert r.returncode == 0, r.stderr
    assert "arm minus control, mach, 2 against 2 runs: -0.0300 - -0.0150 = -0.0150 bootstrap 95% [-0.0200, -0.0100]" \
        in r.stdout, r.stdout
    assert "arm minus control, lead_ft, 2 against 2 runs: -168.0000 - -168.0000 = +0.0000" in r.stdout, r.stdout
    open(control, "w").write("{}")
    r = subprocess.run([sys.executable, SCRIPT, "runs/x", "--control", control], capture_output=True, text=True, env=env)
    assert r.returncode != 0 and "not a file written by race_lines.py --save" in r.stderr and \
        r.stderr.count("\n") == 1, r.stderr
    # A bad race count and a failing replay: one line each.
    r = subprocess.run([sys.executable, SCRIPT, "runs/x", "--races", "0"], capture_output=True, text=True, env=env)
    assert r.returncode != 0 and "at least 1" in r.stderr and r.stderr.count("\n") == 1, r.stderr
    r = subprocess.run([sys.executable, SCRIPT, "runs/x"], capture_output=True, text=True,
                       env=dict(env, F16RACE="/bin/false"))
    assert r.returncode != 0 and "replay --seed 1 failed" in r.stderr and r.stderr.count("\n") == 1, r.stderr
    r = subprocess.run([sys.executable, SCRIPT, "runs/x"], capture_output=True, text=True,
                       env=dict(env, F16RACE=os.path.join(tmp, "missing")))
    assert r.returncode != 0 and "no such binary" in r.stderr and r.stderr.count("\n") == 1, r.stderr
    # A binary from before the throttle columns: one line naming the file and the fix.
    old = FAKE.replace(",throttle_cmd,throttle,power_pct,alpha_rad", "")
    open(fake, "w").write(old)
    r = subprocess.run([sys.executable, SCRIPT, "runs/x", "--races", "1"], capture_output=True, text=True, env=env)
    assert r.returncode != 0 and "no throttle columns" in r.stderr and r.stderr.count("\n") == 1, r.stderr
print("race_lines.py: the known answer, clean races only, an arm against a saved control, bad input in one line")
