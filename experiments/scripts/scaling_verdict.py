#!/usr/bin/env python3
"""Notebook 68's verdict: does the high level's margin over its own center line grow with data?

    experiments/scripts/scaling_verdict.py MULT=STUDY [MULT=STUDY ...]
    experiments/scripts/scaling_verdict.py --keep STUDY KEEP_FILE
    experiments/scripts/scaling_verdict.py --keep-pieces STUDY KEEP_FILE

--keep writes the controls of a budget's runs (each run's summary, as study_verdicts.py keeps
them) to KEEP_FILE (xMULT.json), small enough to commit; MULT=KEEP_FILE then stands for the
study folder. --keep-pieces adds the runs of STUDY that have their controls to KEEP_FILE (made
if absent), each with the CPU and binary that made it: a budget too long for one machine's
lifetime (x16) is trained a few runs at a time, each piece kept when done; the runs not yet in
it read as missing. MULT=FOLDER may also be a folder of the Fig. 3 study's kept blocks (notebook 72),
whose seed 1-3 runs at 8 s are the x2 budget.

Each STUDY is a `study --out` folder trained on one pilot at MULT x 1.75 M HL-only env steps
(experiments/configs/study_scaling.yaml; the Fig. 3 study's own folder stands for MULT 2), with its runs'
controls tournaments in dt8/controls/RUN (notebook 66, "Commands"). Runs es_d2_s1..3 and
es_d3_s1..3 count. c_i = run i's winrate against RUN@center (512 races). The slope of c_i on
log2(MULT) by least squares over all runs; its 95 % interval by bootstrap (10 000 replicates,
Random("68:...")), resampling runs with replacement inside each (budget, variant) cell.
Holds if lo > 0; does not hold if hi < 0.0125 per doubling (0.05 over x16, the study's delta);
otherwise cannot tell at this power. Missing controls are reported as missing, never guessed.
Standard library only.
"""
import json
import math
import os
import random
import sys

sys.path.insert(0, os.path.dirname(os.path.abspath(__file__)))
import kept_json  # noqa: E402
from study_verdicts import HOLDS, NOT, CANNOT, KeptBlocks, percentiles, read_controls  # noqa: E402

RUNS = [f"{v}_s{s}" for v in ("es_d2", "es_d3") for s in (1, 2, 3)]
BASE_STEPS = 1_750_000
BAR = 0.0125  # per doubling: 0.05 over x16
REPS = 10000


def slope(points):
    xs = [x for x, _ in points]
    if len(set(xs)) < 2:
        return None
    mx, my = sum(xs) / len(xs), sum(y for _, y in points) / len(points)
    return sum((x - mx) * (y - my) for x, y in points) / sum((x - mx) ** 2 for x in xs)


def controls_of(path):
    """{run: controls summary or None} at 8 s, from a study folder, a kept budget or kept blocks."""
    if os.path.isfile(path):
        kept = json.load(open(path))["runs"]
    elif any(n.startswith("s") and n.endswith(".json") for n in os.listdir(path)):
        kept = KeptBlocks(path).controls(8)
    else:
        kept = {run: read_controls(path, 8, run) for run in RUNS}
    return {run: kept.get(run) for run in RUNS}


def keep(study, dest):
    got = {run: read_controls(study, 8, run) for run in RUNS}
    absent = [run for run, g in got.items() if g is None]
    if absent:
        sys.exit(f"{study}/dt8/controls/{absent[0]}: no done.txt; race the run's controls first")
    kept_json.write(dest, dict(runs=got, **kept_json.provenance()))


def keep_pieces(study, dest):
    got = {run: c for run, c in ((run, read_controls(study, 8, run)) for run in RUNS) if c is not None}
    if not got:
        sys.exit(f"{study}: no run with its controls raced (dt8/controls/RUN/done.txt); nothing to keep")
    kept = json.load(open(dest)) if os.path.exists(dest) else {"runs": {}, "pieces": {}}
    if "pieces" not in kept:
        sys.exit(f"{dest}: a whole budget kept by --keep; give another KEEP_FILE for pieces")
    for run, c in got.items():
        if run in kept["runs"] and kept["runs"][run] != c:
            sys.exit(f"{dest}: {run} is kept already with other controls; one piece per run")
        kept["runs"][run] = c
        kept["pieces"][run] = kept_json.provenance()
    kept_json.write(dest, kept)
    left = [run for run in RUNS if run not in kept["runs"]]
    print(f"{len(kept['runs'])} of {len(RUNS)} runs kept" + (f"; left: {', '.join(left)}" if left else ""))


def cells_of(studies):
    """{(mult, variant): [c_i]} and the runs whose controls are missing."""
    cells, missing = {}, []
    for mult, folder in studies:
        controls = controls_of(folder)
        for run in RUNS:
            got = controls[run]
            if got is None:
                missing.append(f"x{mult:g} {run}")
                continue
            cells.setdefault((mult, run.rsplit("_s", 1)[0]), []).append(got["vs_center"])
    return cells, missing


def resample(cells, r):
    return {k: [r.choice(v) for _ in v] for k, v in cells.items()}


def points_of(cells):
    return [(math.log2(m), c) for (m, _), cs in cells.items() for c in cs]


def main(argv):
    if argv[:1] == ["--keep"]:
        if len(argv) != 3:
            sys.exit("usage: scaling_verdict.py --keep STUDY KEEP_FILE")
        return keep(argv[1], argv[2])
    if argv[:1] == ["--keep-pieces"]:
        if len(argv) != 3:
            sys.exit("usage: scaling_verdict.py --keep-pieces STUDY KEEP_FILE")
        return keep_pieces(argv[1], argv[2])
    studies = []
    for a in argv:
        mult, _, folder = a.partition("=")
        if not folder or not os.path.exists(folder):
            sys.exit(f"scaling_verdict: {a}: want MULT=STUDY_FOLDER (or a kept xMULT.json) that exists")
        studies.append((float(mult), folder))
    cells, missing = cells_of(studies)
    print("| budget | HL env steps | runs | mean vs @center | 95 % CI |\n|---|---|---|---|---|")
    for mult, _ in sorted(studies):
        sub = {k: v for k, v in cells.items() if k[0] == mult}
        vals = [c for v in sub.values() for c in v]
        if not vals:
            print(f"| x{mult:g} | {mult * BASE_STEPS / 1e6:g} M | 0 | missing | |")
            continue
        r = random.Random(f"68:mean:{mult:g}")
        reps = [sum(sum(v) for v in rs.values()) / len(vals) for rs in (resample(sub, r) for _ in range(REPS))]
        lo, hi = percentiles(reps)
        print(f"| x{mult:g} | {mult * BASE_STEPS / 1e6:g} M | {len(vals)} | {sum(vals) / len(vals):.3f} | "
              f"[{lo:.3f}, {hi:.3f}] |")
    b = slope(points_of(cells))
    if b is None:
        print("\nslope: cannot be computed yet (fewer than two budgets with controls)")
    else:
        r = random.Random("68:slope")
        reps = [slope(points_of(resample(cells, r))) for _ in range(REPS)]
        lo, hi = percentiles(reps)
        verdict = HOLDS if lo > 0 else (NOT if hi < BAR else CANNOT)
        print(f"\nslope per doubling of HL env steps: {b:+.4f} [{lo:+.4f}, {hi:+.4f}] -> grows with data: {verdict}")
    if missing:
        print(f"\nmissing ({len(missing)}): " + ", ".join(missing))


if __name__ == "__main__":
    main(sys.argv[1:])
