#!/usr/bin/env python3
"""experiments/scripts/lane_offset.py on replays whose answer is known. A stand-in binary writes, per seed T,
two blue aircraft and one red: blue 0 flies at +0.2 R right and +0.4 R up (radius 1000 ft) with
-3 R up in its first 5 s (the settling the measure skips); blue 1 is at -0.4 R right and 0 up until
it is taken out at 10 s, then frozen at +5 R up (rows the measure must skip); red sits at +9 R
(not the run's). So over any number of races: right (0.2 x 36 - 0.4 x 26) / 62, up 0.4 x 36 / 62
(36 samples at 5.0-12.0 s and 26 at 5.0-10.0 s, 0.2 s apart, per race)."""
import json
import math
import os
import subprocess
import sys
import tempfile

SCRIPT = sys.argv[1]
FAKE = r'''#!/usr/bin/env python3
import os, sys
a = sys.argv
out = a[a.index("--out") + 1]
assert a[a.index("--run") + 1].endswith("@center") and a[a.index("--opponent") + 1] == "autopilot"
os.makedirs(out)
open(os.path.join(out, "replay.md"), "w").write(
    "| aircraft | team | fate | HL decisions |\n|---|---|---|---|\n"
    "| 0 | blue | in the race at the end | 2 |\n| 1 | blue | out at 10.00 s (tube) | 1 |\n"
    "| 2 | red | in the race at the end | 0 |\n")
def write(agent, lat, vert):
    with open(os.path.join(out, f"replay_agent{agent}.csv"), "w") as f:
        f.write("t_s,s_ft,lateral_ft,vertical_ft,radius_ft\n")
        for k in range(61):
            t = round(0.2 * k, 6)
            f.write(f"{t},0,{lat(t)},{vert(t)},1000\n")
sets = [a[k + 1] for k in range(len(a) - 1) if a[k] == "--set" and a[k + 1].startswith("race.goal_shift_up_frac=")]
shift = float(sets[0].split("=", 1)[1]) if sets else 0.0  # blue 0 follows it
write(0, lambda t: 200.0, lambda t: -3000.0 if t < 5 else 400.0 + 1000.0 * shift)
write(1, lambda t: -400.0, lambda t: 0.0 if t <= 10 else 5000.0)
write(2, lambda t: 9000.0, lambda t: 9000.0)
'''

with tempfile.TemporaryDirectory() as tmp:
    fake = os.path.join(tmp, "f16race")
    open(fake, "w").write(FAKE)
    os.chmod(fake, 0o755)
    env = dict(os.environ, F16RACE=fake)
    right, up = (0.2 * 36 - 0.4 * 26) / 62, 0.4 * 36 / 62
    r = subprocess.run([sys.executable, SCRIPT, "runs/x", "--races", "3"], capture_output=True, text=True, env=env)
    assert r.returncode == 0, r.stderr
    assert f"right {right:+.3f} R, up {up:+.3f} R" in r.stdout, (r.stdout, right, up)
    # --goal-shift-up reaches the replays (notebook 97): blue 0 flies 0.3 R lower in the stand-in.
    r = subprocess.run([sys.executable, SCRIPT, "runs/x", "--races", "2", "--goal-shift-up", "-0.3"], capture_output=True,
                       text=True, env=env)
    assert r.returncode == 0, r.stderr
    assert f"up {(0.4 - 0.3) * 36 / 62:+.3f} R" in r.stdout, r.stdout
    kept = os.path.join(tmp, "s1.json")
    json.dump({"ap": 0.5}, open(kept, "w"))
    r = subprocess.run([sys.executable, SCRIPT, "--add", kept, "runs/x", "--races", "2"], capture_output=True,
                       text=True, env=env)
    assert r.returncode == 0, r.stderr
    m = json.load(open(kept))
    o = m["center_offset"]
    assert m["ap"] == 0.5 and o["races"] == 2 and o["samples"] == 2 * 62, m
    assert abs(o["right"] - right) < 1e-12 and abs(o["up"] - up) < 1e-12, o
    assert abs(o["size"] - math.hypot(right, up)) < 1e-12, o
    # A kept file that is not there, and a bad race count: one line each, nothing written.
    r = subprocess.run([sys.executable, SCRIPT, "--add", os.path.join(tmp, "none.json"), "runs/x"],
                       capture_output=True, text=True, env=env)
    assert r.returncode != 0 and "no kept seed file" in r.stderr and r.stderr.count("\n") == 1, r.stderr
    bad = os.path.join(tmp, "bad.json")
    open(bad, "w").write('{"ap": 0.5,')  # cut short
    r = subprocess.run([sys.executable, SCRIPT, "--add", bad, "runs/x"], capture_output=True, text=True, env=env)
    assert r.returncode != 0 and "not a kept seed file" in r.stderr and r.stderr.count("\n") == 1, r.stderr
    assert open(bad).read() == '{"ap": 0.5,', "a corrupt kept file is left as it was"
    r = subprocess.run([sys.executable, SCRIPT, "runs/x", "--races", "0"], capture_output=True, text=True, env=env)
    assert r.returncode != 0 and "at least 1" in r.stderr, r.stderr
