#!/usr/bin/env python3
"""experiments/scripts/duel_verdict.py (notebook 107's rule) on made-up pieces with known answers.

--keep-piece reads a piece folder whose round robin lists es_d2 as the row (so w = 1 - 0.3 = 0.7)
and whose controls are known; a piece without its controls is refused in one line. The verdict:
eight seeds at 0.60 +- 0.01 hold; at 0.22 +- 0.01 do not hold, reversed; 0.52 +- 0.12 cannot
tell; five seeds are marked provisional; a file that is not a piece is refused.
"""
import json
import os
import subprocess
import sys
import tempfile

SCRIPT = sys.argv[1]


def run(*args):
    return subprocess.run([sys.executable, SCRIPT, *args], capture_output=True, text=True)


def write_csv(path, header, rows):
    os.makedirs(os.path.dirname(path), exist_ok=True)
    with open(path, "w") as f:
        f.write(",".join(header) + "\n")
        for r in rows:
            f.write(",".join(str(x) for x in r) + "\n")


def make_piece(root, seed, with_controls=True):
    study = os.path.join(root, f"x16_s{seed}")
    d2, d3 = f"es_d2_s{seed}", f"es_d3_s{seed}"
    header = ["row", "column", "winrate", "races", "wilson95_lo", "wilson95_hi", "row_entry", "column_entry"]
    write_csv(f"{study}/dt8/tournament/pairings.csv", header,
              [[0, 1, 0.3, 512, 0.26, 0.34, d2, d3], [0, 2, 0.9, 512, 0.87, 0.93, d2, "untrained"]])
    for run_, center_win in ((d2, 0.88), (d3, 0.85)):
        if not with_controls:
            break
        folder = f"{study}/dt8/controls/{run_}"
        write_csv(f"{folder}/pairings.csv", header,
                  [[0, 1, center_win, 4, 0, 1, run_, run_ + "@center"], [0, 2, 0.9, 4, 0, 1, run_, run_ + "@random"]])
        # four races against @center: the run blocks 3, 1, 2, 2 against the center line's 1, 1, 1, 1
        races = [[run_, run_ + "@center", 3, 1], [run_ + "@center", run_, 1, 1], [run_, run_ + "@center", 2, 1],
                 [run_ + "@center", run_, 1, 2], [run_, run_ + "@random", 5, 0]]
        write_csv(f"{folder}/races.csv", ["blue", "red", "blue_blocks", "red_blocks"], races)
        open(f"{folder}/done.txt", "w").write("done\n")
    return study


def write_kept(folder, values):
    os.makedirs(folder)
    for s, w in enumerate(values, start=1):
        c = dict(vs_center=0.8, vs_random=0.9, block_diff_sum=64, center_blocks_sum=512, races=512)
        json.dump(dict(seed=s, d3_vs_d2=w, races=512, cpu="test", controls={f"es_d2_s{s}": c, f"es_d3_s{s}": c}),
                  open(os.path.join(folder, f"s{s}.json"), "w"))


with tempfile.TemporaryDirectory() as tmp:
    study = make_piece(tmp, 5)
    out = run("--keep-piece", study, f"{tmp}/keep")
    assert out.returncode == 0, out
    kept = json.load(open(f"{tmp}/keep/s5.json"))
    assert kept["seed"] == 5 and abs(kept["d3_vs_d2"] - 0.7) < 1e-12 and kept["races"] == 512, kept
    c = kept["controls"]["es_d3_s5"]
    assert c["vs_center"] == 0.85 and c["block_diff_sum"] == 4 and c["center_blocks_sum"] == 4 and c["races"] == 4, c

    bare = make_piece(f"{tmp}/bare", 6, with_controls=False)
    out = run("--keep-piece", bare, f"{tmp}/keep")
    assert out.returncode != 0 and "es_d2_s6: no done.txt" in out.stderr, out
    assert len(out.stderr.strip().splitlines()) == 1 and not os.path.exists(f"{tmp}/keep/s6.json"), out

    spread = [k - 3.5 for k in range(8)]
    cases = {"holds": [0.60 + 0.01 * k / 3.5 for k in spread],
             "reversed": [0.22 + 0.01 * k / 3.5 for k in spread],
             "cannot": [0.52 + 0.12 * k / 3.5 for k in spread]}
    for name, values in cases.items():
        write_kept(f"{tmp}/{name}", values)
    out = run(f"{tmp}/holds")
    assert out.returncode == 0 and "M(es_d3, es_d2) = 0.600" in out.stdout and "**holds**" in out.stdout, out
    assert "Provisional" not in out.stdout and "| +0.12 | +0.12 |" in out.stdout, out.stdout
    out = run(f"{tmp}/reversed")
    assert "**does not hold (reversed)**" in out.stdout, out.stdout
    out = run(f"{tmp}/cannot")
    assert "**cannot tell at this power**" in out.stdout, out.stdout

    write_kept(f"{tmp}/five", cases["holds"][:5])
    out = run(f"{tmp}/five")
    assert out.returncode == 0 and "5 of the 8 pre-registered seeds kept" in out.stdout, out
    assert "M(es_d3" not in out.stdout and "0.6" not in out.stdout, out.stdout  # nothing read early

    os.makedirs(f"{tmp}/bad")
    json.dump({"seed": 1}, open(f"{tmp}/bad/s1.json", "w"))
    out = run(f"{tmp}/bad")
    assert out.returncode != 0 and "s1.json: not a kept piece" in out.stderr, out
    assert len(out.stderr.strip().splitlines()) == 1, out.stderr

    os.makedirs(f"{tmp}/torn")
    open(f"{tmp}/torn/s1.json", "w").write('{"seed": 1, "d3_vs')
    out = run(f"{tmp}/torn")
    assert out.returncode != 0 and "s1.json: unreadable" in out.stderr, out
    assert len(out.stderr.strip().splitlines()) == 1, out.stderr

print("duel_verdict: kept pieces, holds, reversed, cannot tell, too few seeds and bad input as expected")
