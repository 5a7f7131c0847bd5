#!/usr/bin/env python3
"""Is the height in the tube pace? The two measures of experiments/notebook/96.

    experiments/scripts/vertical_pace.py pilots ARM_DIR [ARM_DIR ...]
        Over the kept seed summaries (ARM_DIR/sS.json of experiments/scripts/pilot_seeds_table.py with
        experiments/scripts/lane_offset.py's "center_offset"): Pearson correlations between the low level's
        steady vertical offset under its middle bin (/ R), its airspeed in training's last tenth and
        its winrate against the autopilot, with a bootstrap 95 % CI over pilots, and the slopes.
    experiments/scripts/vertical_pace.py shifts DIR SHIFT [SHIFT ...]
        Tournaments DIR/shiftX/t_sS (S = 1..8) of run sS against the autopilot moved up by X of the
        radius (tournament --set race.autopilot_shift_up_frac=X): each seed's winrate and the autopilot's tube
        losses per race, and the paired difference of each shift against the first, bootstrapped over
        the seeds.
    experiments/scripts/vertical_pace.py tuned CONTROL_DIR TREATMENT_DIR SHIFT [SHIFT ...]
        Notebook 96's rule: in each arm (DIR as for shifts) the tuned autopilot is the shift with
        the lowest mean winrate of the eight runs; the difference of the arms' means against their
        tuned autopilots (treatment - control, seeds resampled within each arm) and each arm's
        Claim A count (seeds whose Wilson 95 % lower bound is above 0.6).

Standard library only; one line on stderr and exit 1 on a missing or malformed file.
"""
import csv
import json
import os
import random
import statistics as st
import sys

BOOT = 10000


def fail(msg):
    print(f"vertical_pace.py: {msg}", file=sys.stderr)
    sys.exit(1)


def corr(x, y):
    mx, my = st.mean(x), st.mean(y)
    sxy = sum((a - mx) * (b - my) for a, b in zip(x, y))
    sxx = sum((a - mx) ** 2 for a in x)
    syy = sum((b - my) ** 2 for b in y)
    return sxy / (sxx * syy) ** 0.5 if sxx > 0 and syy > 0 else float("nan")


def slope(x, y):
    mx, my = st.mean(x), st.mean(y)
    return sum((a - mx) * (b - my) for a, b in zip(x, y)) / sum((a - mx) ** 2 for a in x)


def ci(values):
    v = sorted(values)
    return v[int(0.025 * len(v))], v[int(0.975 * len(v)) - 1]


def pilots(arm_dirs):
    rows = []
    for d in arm_dirs:
        names = sorted(f for f in os.listdir(d) if f.startswith("s") and f.endswith(".json")) if os.path.isdir(d) else []
        if not names:
            fail(f"{d}: no kept seed summaries (sS.json)")
        for f in names:
            p = os.path.join(d, f)
            try:
                j = json.load(open(p))
                rows.append((j["center_offset"]["up"], j["v"], j["ap"]))
            except (OSError, ValueError, KeyError, TypeError) as e:
                fail(f"{p}: not a kept seed summary with center_offset.up, v and ap ({e})")
    if len(rows) < 4:
        fail(f"{len(rows)} pilots: a correlation needs at least 4")
    rng = random.Random(1)
    print(f"{len(rows)} pilots ({', '.join(arm_dirs)})")
    for name, i, j in (("up, airspeed", 0, 1), ("up, vs autopilot", 0, 2), ("airspeed, vs autopilot", 1, 2)):
        boots = []
        for _ in range(BOOT):
            s = rng.choices(rows, k=len(rows))
            boots.append(corr([r[i] for r in s], [r[j] for r in s]))
        lo, hi = ci([b for b in boots if b == b])  # a resample of one repeated pilot has no correlation
        print(f"corr({name}): {corr([r[i] for r in rows], [r[j] for r in rows]):+.2f} bootstrap 95% [{lo:+.2f}, {hi:+.2f}]")
    up, v, ap = zip(*rows)
    print(f"slope: airspeed {slope(up, v):+.2f} ft/s per R of vertical offset; vs autopilot {slope(v, ap):+.3f} per ft/s")


def seed_result(path, seed):
    try:
        races = list(csv.DictReader(open(path)))
    except OSError as e:
        fail(f"{path}: {e.strerror}")
    if not races or "winner" not in races[0]:
        fail(f"{path}: no races with a winner column")
    me = f"s{seed}"
    score = tube = 0.0
    for r in races:
        score += 1.0 if r["winner"] == me else 0.0 if r["winner"] == "autopilot" else 0.5
        side = "blue" if r["blue"] == "autopilot" else "red"
        tube += int(r[f"{side}_out_tube"])
    return score / len(races), tube / len(races)


def shifts(root, values):
    res = {x: [seed_result(os.path.join(root, f"shift{x}", f"t_s{s}", "races.csv"), s) for s in range(1, 9)] for x in values}
    print("| seed | " + " | ".join(f"vs autopilot moved {x} R (its tube losses per race)" for x in values) + " |")
    print("|---" * (len(values) + 1) + "|")
    for s in range(8):
        print(f"| {s + 1} | " + " | ".join(f"{res[x][s][0]:.3f} ({res[x][s][1]:.3f})" for x in values) + " |")
    print("| mean | " + " | ".join(f"{st.mean(w for w, _ in res[x]):.3f} ({st.mean(t for _, t in res[x]):.3f})" for x in values) + " |")
    rng = random.Random(1)
    base = [w for w, _ in res[values[0]]]
    for x in values[1:]:
        d = [w - b for (w, _), b in zip(res[x], base)]
        lo, hi = ci([st.mean(rng.choices(d, k=len(d))) for _ in range(BOOT)])
        print(f"moved {x} R minus moved {values[0]} R, the run's winrate: {st.mean(d):+.3f} bootstrap 95% [{lo:+.3f}, {hi:+.3f}], "
              f"lower in {sum(v < 0 for v in d)} of 8 seeds")


def wilson_lo(p, n, z=1.96):
    return (p + z * z / (2 * n) - z * ((p * (1 - p) + z * z / (4 * n)) / n) ** 0.5) / (1 + z * z / n)


def tuned(control, treatment, values):
    arms = {}
    for name, root in (("control", control), ("treatment", treatment)):
        res = {}
        for x in values:
            rows = [seed_result(os.path.join(root, f"shift{x}", f"t_s{s}", "races.csv"), s) for s in range(1, 9)]
            res[x] = [w for w, _ in rows]
        best = min(values, key=lambda x: st.mean(res[x]))
        n = len(list(csv.DictReader(open(os.path.join(root, f"shift{best}", "t_s1", "races.csv")))))
        claim = sum(wilson_lo(w, n) > 0.6 for w in res[best])
        arms[name] = res[best]
        print(f"{name}: tuned autopilot moved {best} R; the runs' mean {st.mean(res[best]):.3f}; Claim A {claim} of 8 "
              f"({', '.join(f'{x} R {st.mean(res[x]):.3f}' for x in values)})")
    rng = random.Random(1)
    boots = [st.mean(rng.choices(arms["treatment"], k=8)) - st.mean(rng.choices(arms["control"], k=8)) for _ in range(BOOT)]
    lo, hi = ci(boots)
    print(f"treatment - control against their tuned autopilots: {st.mean(arms['treatment']) - st.mean(arms['control']):+.3f} "
          f"bootstrap 95% [{lo:+.3f}, {hi:+.3f}]")


def main(argv):
    if len(argv) >= 2 and argv[0] == "pilots":
        pilots(argv[1:])
    elif len(argv) >= 3 and argv[0] == "shifts":
        shifts(argv[1], argv[2:])
    elif len(argv) >= 4 and argv[0] == "tuned":
        tuned(argv[1], argv[2], argv[3:])
    else:
        fail("usage: vertical_pace.py pilots ARM_DIR ... | shifts DIR SHIFT SHIFT ... | tuned CONTROL_DIR TREATMENT_DIR SHIFT ...")


if __name__ == "__main__":
    main(sys.argv[1:])
