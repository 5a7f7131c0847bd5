#!/usr/bin/env python3
"""Notebook 64's table: learned low levels against the tuned autopilot, per seed and over seeds.

    experiments/scripts/pilot_seeds_table.py EXPERIMENT_DIR [--control CONTROL_DIR]

EXPERIMENT_DIR holds, per seed S, the run `sS` (its metrics.csv) and the tournament `t_sS`
(`tournament --runs sS --no-untrained --with-autopilot --controls`; a seed counts once
`t_sS/done.txt` exists). Prints Markdown: per seed the winrate against the autopilot, `@center`
and `@random` (Wilson 95 %), airspeed of training's last tenth, the median race, aircraft lost per
race by cause for both teams of the autopilot pairing, and the winrate in the races neither team
lost an aircraft; then the pre-registered claims over seeds (bootstrap 95 % CIs). With
--control, an A/B of EXPERIMENT_DIR (treatment) against CONTROL_DIR (the same layout): the
difference of the arms' mean winrates against the autopilot, its bootstrap 95 % CI (seeds
resampled within each arm, 10 000 resamples, random seed 67) and notebook 67's verdict: adopt
when the CI lies above 0, worse when below, else not resolved; and, as notebook 71's secondary
measure, the arms' tube exits per race in training's first tenth of updates (metrics.csv's
`term_tube` weighted by `races`) with the same CI; and, where the kept files have it
(`experiments/scripts/lane_offset.py --add`, notebook 74), the low level's steady offset from its lane.
Standard library.

    experiments/scripts/pilot_seeds_table.py --keep EXPERIMENT_DIR SEED KEEP_DIR
    experiments/scripts/pilot_seeds_table.py --add-center-lost EXPERIMENT_DIR SEED KEEP_FILE

writes KEEP_DIR/sSEED.json: the seed's row and measures, the CPU, the binary and the training
wall time. A folder of such files reads as an EXPERIMENT_DIR (a seed's kept file stands for its
run and tournament), so an A/B whose seeds ran on several machines, and whose run folders are
gone, is still read from the repository. --add-center-lost adds to a kept file what later
kept files hold as `center_lost` (the middle bin's losses against the autopilot, notebook 89),
from the seed's tournament.
"""
import csv
import json
import math
import os
import random
import sys

sys.path.insert(0, os.path.dirname(os.path.abspath(__file__)))
import kept_json  # noqa: E402

CAUSES = ["team_collision", "collision", "tube", "altitude", "load", "turn_rate", "simulator", "envelope"]


def wilson(w, n, z=1.96):
    if n == 0:
        return (float("nan"),) * 2
    p = w / n
    d = 1 + z * z / n
    c = p + z * z / (2 * n)
    h = z * math.sqrt(p * (1 - p) / n + z * z / (4 * n * n))
    return ((c - h) / d, (c + h) / d)


def boot(xs, reps=10000, seed=1):
    """Percentile bootstrap 95 % CI of the mean over seeds."""
    rng = random.Random(seed)
    n = len(xs)
    ms = sorted(sum(rng.choice(xs) for _ in range(n)) / n for _ in range(reps))
    return ms[int(0.025 * reps)], ms[int(0.975 * reps) - 1]


def head_to_head(rows, me, opp):
    """Score of `me` against `opp` (a draw is half a win), each team's losses per race by cause,
    the median race, and the score over the races in which neither team lost an aircraft."""
    h = dict(w=0.0, n=0, clean_w=0.0, clean_n=0, durations=[], block_diff=0,
             lost={c: 0 for c in CAUSES}, opp_lost={c: 0 for c in CAUSES})
    for r in rows:
        if {r["blue"], r["red"]} != {me, opp}:
            continue
        side, other = ("blue", "red") if r["blue"] == me else ("red", "blue")
        score = 1.0 if r["winner"] == me else (0.5 if r["winner"] == "draw" else 0.0)
        h["n"] += 1
        h["w"] += score
        for c in CAUSES:
            h["lost"][c] += int(float(r[f"{side}_out_{c}"]))
            h["opp_lost"][c] += int(float(r[f"{other}_out_{c}"]))
        if int(r["blue_terminated"]) == 0 and int(r["red_terminated"]) == 0:
            h["clean_n"] += 1
            h["clean_w"] += score
        h["durations"].append(float(r["duration_s"]))
        if "blue_blocks" in r:
            h["block_diff"] += int(float(r[f"{side}_blocks"])) - int(float(r[f"{other}_blocks"]))
    n = max(h["n"], 1)
    h["block_diff"] /= n
    for key in ("lost", "opp_lost"):
        h[key] = {c: v / n for c, v in h[key].items()}
    d = sorted(h["durations"])
    h["median_s"] = d[len(d) // 2] if d else float("nan")
    return h


def last_tenth(path, col):
    rows = list(csv.DictReader(open(path)))
    k = max(1, len(rows) // 10)
    xs = [float(r[col]) for r in rows[-k:] if r[col] not in ("", "nan")]
    return sum(xs) / len(xs) if xs else float("nan")


def first_tenth_per_race(path, col):
    """Training's first tenth of updates: `col` (a per-race rate) weighted by each row's races."""
    rows = list(csv.DictReader(open(path)))
    races = rate = 0.0
    for r in rows[:max(1, len(rows) // 10)]:
        n = float(r.get("races") or 0)
        if n > 0 and r.get(col) not in (None, "", "nan"):
            races += n
            rate += n * float(r[col])
    return rate / races if races > 0 else float("nan")


def fmt_ci(w, n):
    if n == 0:
        return "n/a"
    lo, hi = wilson(w, n)
    return f"{w / n:.3f} [{max(lo, 0.0):.3f}, {min(hi, 1.0):.3f}]"


def seed_row(folder, s, show=True):
    kept = os.path.join(folder, f"s{s}.json")
    if os.path.exists(kept):
        m = json.load(open(kept))
        (print if show else (lambda *a: None))(m["row"])
        return m
    m = measure_seed(folder, s)
    (print if show else (lambda *a: None))(m["row"])
    return m


def measure_seed(folder, s):
    rows = list(csv.DictReader(open(os.path.join(folder, f"t_s{s}", "races.csv"))))
    me = f"s{s}"
    ap = head_to_head(rows, me, "autopilot")
    c = head_to_head(rows, me, me + "@center")
    r = head_to_head(rows, me, me + "@random")
    # The low level alone: both teams on the center line, the learned pilot against the autopilot.
    lc = head_to_head(rows, me + "@center", "autopilot")
    v = last_tenth(os.path.join(folder, me, "metrics.csv"), "airspeed_ftps")
    lost = lambda d: ", ".join(f"{d[k]:.3f}" for k in ("team_collision", "collision", "tube", "envelope"))
    row = (f"| {s} | {fmt_ci(ap['w'], ap['n'])} | {fmt_ci(c['w'], c['n'])} | {fmt_ci(r['w'], r['n'])} | {v:.0f} "
          f"| {ap['median_s']:.1f} | {lost(ap['lost'])} | {lost(ap['opp_lost'])} "
          f"| {fmt_ci(ap['clean_w'], ap['clean_n'])} ({ap['clean_n']}) |")
    others = [k for k in CAUSES if k not in ("team_collision", "collision", "tube", "envelope")]
    early_tube = first_tenth_per_race(os.path.join(folder, me, "metrics.csv"), "term_tube")
    # Notebook 106: the share of the tournament's races that end at the finish line (end_reason 1),
    # the race's length against the own center line and the blocks made there more than it.
    finish = (sum(int(float(x["end_reason"])) == 1 for x in rows) / len(rows)) if rows and "end_reason" in rows[0] else None
    return dict(finish=finish, center_median_s=c["median_s"], blocks_vs_center=c["block_diff"] if c["n"] else None,row=row, ap=ap["w"] / ap["n"], ap_lo=wilson(ap["w"], ap["n"])[0], c=c["w"] / c["n"], r=r["w"] / r["n"], v=v,
                early_tube=early_tube, ll_center_vs_ap=lc["w"] / lc["n"] if lc["n"] else None,
                clean=ap["clean_w"] / max(ap["clean_n"], 1), lost=ap["lost"], center_lost=lc["lost"],
                other_lost=sum(ap["lost"][k] + ap["opp_lost"][k] for k in others))


def summary(per):
    k = sum(p["ap_lo"] > 0.6 for p in per)
    lo, hi = wilson(k, len(per))
    lo, hi = max(lo, 0.0), min(hi, 1.0)  # rounding puts the bound at -0.00 when k = 0
    print(f"\nClaim A, seeds beating the tuned autopilot (Wilson lower bound > 0.6): {k} of {len(per)} [{lo:.2f}, {hi:.2f}]")
    m, b = mean_ci([p["lost"]["team_collision"] for p in per])
    print(f"Claim B, teammate collisions per race vs the autopilot: mean {m:.3f} bootstrap 95% [{b[0]:.3f}, {b[1]:.3f}]")
    for key, name in (("ap", "vs autopilot"), ("clean", "vs autopilot, races without losses"), ("c", "vs @center"),
                      ("r", "vs @random"), ("v", "airspeed ft/s"),
                      ("ll_center_vs_ap", "its low level on the center line (@center) vs the autopilot")):
        xs = [p[key] for p in per if p.get(key) is not None]
        if not xs:
            continue
        m, b = mean_ci(xs)
        sd = math.sqrt(sum((x - m) ** 2 for x in xs) / (len(xs) - 1)) if len(xs) > 1 else 0.0
        print(f"{name}: mean {m:.3f} std {sd:.3f} bootstrap 95% [{b[0]:.3f}, {b[1]:.3f}]")
    for c in CAUSES:
        m, b = mean_ci([p["lost"][c] for p in per])
        print(f"run's team lost per race vs the autopilot, {c}: mean {m:.3f} [{b[0]:.3f}, {b[1]:.3f}]")
    offsets = [p["center_offset"]["size"] for p in per if "center_offset" in p]
    if offsets:  # experiments/scripts/lane_offset.py --add (notebook 74's mechanism)
        m, b = mean_ci(offsets)
        print(f"its low level's steady offset from the lane (@center, / R), {len(offsets)} seeds: mean {m:.3f} "
              f"[{b[0]:.3f}, {b[1]:.3f}]")


def difference_ci(treatment, control, reps=10000, seed=67):
    """Difference of means (treatment - control) and its percentile bootstrap 95 % CI, each arm's
    seeds resampled within the arm."""
    rng = random.Random(seed)
    mean = lambda xs: sum(xs) / len(xs)
    diffs = sorted(mean([rng.choice(treatment) for _ in treatment]) - mean([rng.choice(control) for _ in control])
                   for _ in range(reps))
    return mean(treatment) - mean(control), diffs[int(0.025 * reps)], diffs[int(0.975 * reps) - 1]


def ab_difference(treatment, control, reps=10000, seed=67):
    """difference_ci and the verdict of notebook 67's rule."""
    d, lo, hi = difference_ci(treatment, control, reps, seed)
    verdict = "adopt (CI above 0)" if lo > 0 else ("worse (CI below 0)" if hi < 0 else "not resolved (CI contains 0)")
    return d, lo, hi, verdict


def paired_difference_ci(treatment, control, reps=10000, seed=67):
    """Mean of the per-seed differences (treatment - control, the same seeds in order) and its
    percentile bootstrap 95 % CI over seeds: for arms that are one run until a switch acts
    (notebook 105), where the seed's own draw cancels."""
    d = [a - b for a, b in zip(treatment, control)]
    return (sum(d) / len(d), *boot(d, reps, seed))


def finished_seeds(folder):
    return [s for s in range(1, 100) if os.path.exists(os.path.join(folder, f"t_s{s}", "done.txt"))
            or os.path.exists(os.path.join(folder, f"s{s}.json"))]


def keep(folder, s, dest):
    """Writes dest/sS.json: the seed's measures and where they came from (atomically: a stop
    leaves the old file or the new one)."""
    if not os.path.exists(os.path.join(folder, f"t_s{s}", "done.txt")):
        sys.exit(f"{folder}/t_s{s}: no done.txt; finish the seed's tournament first")
    m = measure_seed(folder, s)
    run = os.path.join(folder, f"s{s}", "checkpoint")
    latest = os.path.join(run, open(os.path.join(run, "LATEST")).read().strip())
    m.update(kept_json.provenance())
    m["meta"] = open(os.path.join(latest, "meta.yaml")).read()
    m["train_wall_s"] = float(open(os.path.join(latest, "wall_s.txt")).read())
    m["tournament"] = open(os.path.join(folder, f"t_s{s}", "done.txt")).read()
    kept_json.write(os.path.join(dest, f"s{s}.json"), m)


def add_center_lost(folder, s, kept_file):
    """Adds `center_lost` (the run's middle bin against the autopilot: its team's losses per race by
    cause) to a seed's kept file from the seed's tournament, for files kept before it was measured."""
    rows = list(csv.DictReader(open(os.path.join(folder, f"t_s{s}", "races.csv"))))
    m = json.load(open(kept_file))
    m["center_lost"] = head_to_head(rows, f"s{s}@center", "autopilot")["lost"]
    kept_json.write(kept_file, m)


def mean_ci(xs):
    m = sum(xs) / len(xs)
    return m, (boot(xs) if len(xs) > 1 else (m, m))


def main():
    args = sys.argv[1:]
    if args[:1] == ["--add-center-lost"]:
        if len(args) != 4 or not args[2].isdigit():
            sys.exit("usage: experiments/scripts/pilot_seeds_table.py --add-center-lost EXPERIMENT_DIR SEED KEEP_FILE")
        return add_center_lost(args[1], int(args[2]), args[3])
    if args[:1] == ["--keep"]:
        if len(args) != 4 or not args[2].isdigit():
            sys.exit("usage: experiments/scripts/pilot_seeds_table.py --keep EXPERIMENT_DIR SEED KEEP_DIR")
        return keep(args[1], int(args[2]), args[3])
    control = None
    if len(args) == 3 and args[1] == "--control":
        control = args[2]
        args = args[:1]
    if len(args) != 1 or not os.path.isdir(args[0]) or (control is not None and not os.path.isdir(control)):
        sys.exit("usage: experiments/scripts/pilot_seeds_table.py EXPERIMENT_DIR [--control CONTROL_DIR] (folders with sS/ and t_sS/)")
    folder = args[0]
    seeds = finished_seeds(folder)
    if not seeds:
        sys.exit(f"{folder}: no finished seed (t_sS/done.txt or sS.json); run the tournaments first")
    print("| seed | vs autopilot [95 % Wilson] | vs @center | vs @random | airspeed ft/s (last tenth) "
          "| median race s | run lost per race: team collision, collision, tube, envelope "
          "| autopilot lost per race: same causes | vs autopilot, races without losses (races) |")
    print("|---|---|---|---|---|---|---|---|---|")
    per = [seed_row(folder, s) for s in seeds]
    summary(per)
    if control is not None:
        base = [seed_row(control, s, show=False) for s in finished_seeds(control)]
        if not base:
            sys.exit(f"{control}: no finished seed (t_sS/done.txt or sS.json)")
        d, lo, hi, verdict = ab_difference([p["ap"] for p in per], [p["ap"] for p in base])
        print(f"\nA/B vs autopilot, {len(per)} seeds against {len(base)} of {control}: difference of means "
              f"{d:+.3f} bootstrap 95% [{lo:+.3f}, {hi:+.3f}]: {verdict}")
        base_seeds = finished_seeds(control)
        common = [s for s in seeds if s in base_seeds]
        if common:
            t_ap = [per[seeds.index(s)]["ap"] for s in common]
            c_ap = [base[base_seeds.index(s)]["ap"] for s in common]
            d, lo, hi = paired_difference_ci(t_ap, c_ap)
            verdict = "adopt (CI above 0)" if lo > 0 else ("worse (CI below 0)" if hi < 0 else "not resolved (CI contains 0)")
            same = sum(a == b for a, b in zip(t_ap, c_ap))
            print(f"Paired over the {len(common)} seeds of both arms (per seed, treatment - control): mean {d:+.3f} "
                  f"bootstrap 95% [{lo:+.3f}, {hi:+.3f}]: {verdict}; {same} seeds with the same winrate")
        # Mechanism measures, each where both arms keep it: the low level under the middle bin
        # (notebook 86), the tube losses of the run and of its middle bin (89), the middle bin's
        # steady offset from the lane and its vertical part (74, 103), the winrate in races without
        # losses (pace: 101), the tube exits early in training.
        measures = (
            ("its low level under the middle bin (@center) vs the autopilot", lambda p: p.get("ll_center_vs_ap")),
            ("run's team lost to the tube per race vs the autopilot", lambda p: p["lost"]["tube"]),
            ("@center's team lost to the tube per race vs the autopilot",
             lambda p: p["center_lost"]["tube"] if "center_lost" in p else None),
            ("steady offset from the lane (@center, / R)",
             lambda p: p["center_offset"]["size"] if "center_offset" in p else None),
            ("steady vertical offset from the center-line (@center, up / R)",
             lambda p: p["center_offset"]["up"] if "center_offset" in p else None),
            ("winrate vs the autopilot in races without losses", lambda p: p.get("clean")),
            ("tube exits per race in training's first tenth",
             lambda p: None if math.isnan(p["early_tube"]) else p["early_tube"]))
        for name, get in measures:
            t, c = [get(p) for p in per if get(p) is not None], [get(p) for p in base if get(p) is not None]
            if t and c:
                d, lo, hi = difference_ci(t, c)
                print(f"{name[0].upper() + name[1:]}: treatment {sum(t) / len(t):.3f}, control {sum(c) / len(c):.3f}, "
                      f"difference {d:+.3f} bootstrap 95% [{lo:+.3f}, {hi:+.3f}]")

if __name__ == "__main__":
    main()
