#!/usr/bin/env python3
"""experiments/scripts/line_duel.py on two race folders whose answer is known. Four tracks of 2 vs 2, the line
on blue in A and on red in B. Track 0: both races clean, the line wins both. Track 1: clean, the
line wins in A, the lanes in B. Track 2: in A the line team loses one aircraft to the tube and
still wins (unclean); in B clean, drawn. Track 3: in A a collision takes one of each team, the
lanes win; in B clean, the line wins. The counts are spelled out at the checks below."""
import json
import os
import subprocess
import sys
import tempfile

SCRIPT = sys.argv[1]
HEAD = "race,duration_s,winner_team,alive_at_end,track_length_ft,terminations,end\n"
N = "none"


def folder(root, name, rows):
    d = os.path.join(root, name)
    os.makedirs(d)
    with open(os.path.join(d, "races.csv"), "w") as f:
        f.write(HEAD)
        for k, (dur, winner, causes, length) in enumerate(rows):
            f.write(f"{k},{dur},{winner},{causes.count(N)},{length},{';'.join(causes)},finish line\n")
    return d


def run(*args):
    return subprocess.run([sys.executable, SCRIPT, *args], capture_output=True, text=True)


with tempfile.TemporaryDirectory() as root:
    a = folder(root, "a", [(40, 0, [N, N, N, N], 30000), (42, 0, [N, N, N, N], 31000),
                           (44, 0, ["tube", N, N, N], 32000), (46, 1, ["collision", N, "collision", N], 33000)])
    b = folder(root, "b", [(40, 1, [N, N, N, N], 30000), (42, 0, [N, N, N, N], 31000),
                           (44, -1, [N, N, N, N], 32000), (46, 1, [N, N, N, N], 33000)])
    out = os.path.join(root, "duel.json")
    r = run(a, b, "--json", out)
    assert r.returncode == 0, r.stderr
    j = json.load(open(out))
    p = j["point"]
    # Clean: A0, A1, B0, B1, B2, B3 = 6; the line won A0, A1, B0, B3 and drew B2: 4.5 of 6.
    assert abs(p["clean_share"] - 6 / 8) < 1e-12, p
    assert abs(p["clean_winrate"] - 4.5 / 6) < 1e-12, p
    # All races: A0 A1 A2 won, A3 lost, B0 won, B1 lost, B2 drawn, B3 won: 5.5 of 8.
    assert abs(p["winrate"] - 5.5 / 8) < 1e-12, p
    assert abs(p["line_lost_per_race"] - 2 / 8) < 1e-12 and abs(p["lanes_lost_per_race"] - 1 / 8) < 1e-12, p
    assert abs(p["duration_s"] - 43.0) < 1e-12, p
    assert j["line_lost_by_cause"] == {"collision": 1 / 8, "tube": 1 / 8}, j
    assert j["lanes_lost_by_cause"] == {"collision": 1 / 8}, j
    lo, hi = j["ci95"]["clean_winrate"]
    assert 0.0 <= lo <= p["clean_winrate"] <= hi <= 1.0, j["ci95"]
    assert "4 tracks, 8 races" in r.stdout, r.stdout
    # Bad input: one line each, non-zero exit.
    c = folder(root, "c", [(40, 1, [N, N, N, N], 99999)] * 4)
    for args, says in [((a, c), "different tracks"), ((a, os.path.join(root, "none")), "races.csv"),
                       ((a,), "usage"), ((a, folder(root, "d", [(40, 1, [N] * 4, 30000)])), "1: race both")]:
        r = run(*args)
        assert r.returncode != 0 and says.lower() in (r.stderr + r.stdout).lower(), (args, r.stdout, r.stderr)
print("line_duel.py: OK")
