#!/usr/bin/env python3
"""Notebook 66's verdicts: the paper's high-level claims from a Fig. 3 study on one frozen pilot.

    experiments/scripts/study_verdicts.py STUDY_A [STUDY_B]
    experiments/scripts/study_verdicts.py --keep-block BLOCK_STUDY KEEP_DIR

With --keep-block, BLOCK_STUDY is a study of one seed (notebook 72's blocks: the four variants of
seed S at both intervals, their round robin and each run's controls); its measures, CPU and binary
go to KEEP_DIR/sS.json, small enough to commit. A STUDY_x folder holding such sS.json files is read
as a blocked study: M(u, v) is the mean over seeds S of u_sS's winrate against v_sS, and its
bootstrap resamples seeds (the same resampled seeds at both intervals, so (e2) is paired).

STUDY_x is a `study --out` folder of experiments/configs/study_pilot.yaml: per interval dtD (8, 20) the runs
`dtD/VARIANT_sS`, the round robin `dtD/tournament/pairings.csv`, and per run its controls
tournament `dtD/controls/VARIANT_sS/` (pairings.csv, races.csv). Implements the decision rules of
experiments/notebook/66 as written there, before any run: per claim, pilot and interval "holds", "does
not hold" or "cannot tell at this power"; with two studies, the cross-pilot verdict. Missing
pieces (an interval not raced yet, controls not run) are reported as missing, never guessed.
Bootstraps: 10 000 replicates, random seed 50 (Python's Random, seeded with "50:" + what is
resampled, so each quantity's replicates do not depend on which others were computed). Standard
library only.
"""
import csv
import json
import os
import random
import sys

sys.path.insert(0, os.path.dirname(os.path.abspath(__file__)))
import kept_json  # noqa: E402

VARIANTS = ["es", "es_d1", "es_d2", "es_d3"]
INTERVALS = [8, 20]
DELTA = 0.05  # the smallest difference of pairing winrate the study resolves
PLANNED_BLOCKS = 24  # seeds per pilot in notebook 72's power analysis
REPS = 10000
HOLDS, NOT, CANNOT = "holds", "does not hold", "cannot tell at this power"


def rng(label):
    return random.Random("50:" + label)


def percentiles(values):
    s = sorted(values)
    return s[int(0.025 * (len(s) - 1))], s[int(0.975 * (len(s) - 1))]


def variant_of(name):
    head = name.rsplit("_s", 1)[0]
    return head if head in VARIANTS else None


def round_robin(study, dt):
    """{(run_i, run_j): winrate of i against j} in both directions, or None if not raced yet."""
    path = os.path.join(study, f"dt{dt}", "tournament", "pairings.csv")
    if not os.path.exists(path):
        return None
    w = {}
    with open(path) as f:
        for r in csv.DictReader(f):
            a, b, x = r["row_entry"], r["column_entry"], float(r["winrate"])
            w[(a, b)] = x
            w.setdefault((b, a), 1.0 - x)
    return w


def runs_by_variant(w):
    runs = {v: set() for v in VARIANTS}
    for a, _ in w:
        v = variant_of(a)
        if v:
            runs[v].add(a)
    return {v: sorted(r) for v, r in runs.items()}


def match_replicates(w, us, vs, label):
    """M(u, v) and its stratified-bootstrap replicates (resample the runs of u and of v)."""
    m = [[w[(i, j)] for j in vs] for i in us]
    point = sum(map(sum, m)) / (len(us) * len(vs))
    r = rng(label)
    reps = []
    nu, nv = len(us), len(vs)
    for _ in range(REPS):
        iu = [r.randrange(nu) for _ in range(nu)]
        jv = [r.randrange(nv) for _ in range(nv)]
        reps.append(sum(m[i][j] for i in iu for j in jv) / (nu * nv))
    return point, reps


def block_replicates(w, us, vs, label):
    """M(u, v) over same-seed pairings (u_sS against v_sS) and its bootstrap replicates, seeds
    resampled. The label names no interval, so both intervals resample the same seeds."""
    seed = lambda run: int(run.rsplit("_s", 1)[1])
    vs_by_seed = {seed(j): j for j in vs}
    pairs = [(i, vs_by_seed[seed(i)]) for i in sorted(us, key=seed) if seed(i) in vs_by_seed]
    if not pairs:
        return float("nan"), [float("nan")]
    x = [w[p] for p in pairs]
    r = rng(label)
    reps = [sum(x[r.randrange(len(x))] for _ in x) / len(x) for _ in range(REPS)]
    return sum(x) / len(x), reps


class StudyFolder:
    """A `study --out` folder: one round robin over every run of an interval."""
    blocked = False

    def __init__(self, path):
        self.path = path

    def round_robin(self, dt):
        return round_robin(self.path, dt)

    def controls(self, dt):
        folder = os.path.join(self.path, f"dt{dt}")
        names = sorted(os.listdir(folder)) if os.path.isdir(folder) else []
        return {d: read_controls(self.path, dt, d) for d in names if variant_of(d)}

    def match(self, w, us, vs, tag, dt, u, v):
        return match_replicates(w, us, vs, f"{tag}:{dt}:{u}:{v}")


class KeptBlocks:
    """A folder of sS.json files (--keep-block): one round robin per seed."""
    blocked = True

    def __init__(self, path):
        self.blocks = [json.load(open(os.path.join(path, n))) for n in sorted(os.listdir(path))
                       if n.startswith("s") and n.endswith(".json")]

    def round_robin(self, dt):
        w = {}
        for b in self.blocks:
            for a, c, x in b["intervals"][str(dt)]["pairings"]:
                w[(a, c)] = x
                w.setdefault((c, a), 1.0 - x)
        return w or None

    def controls(self, dt):
        return {run: got for b in self.blocks for run, got in b["intervals"][str(dt)]["controls"].items()}

    def match(self, w, us, vs, tag, dt, u, v):
        return block_replicates(w, us, vs, f"{tag}:blocks:{u}:{v}")


def open_study(path):
    if not os.path.isdir(path):
        sys.exit(f"{path}: not a study folder (give the --out folder of `f16race study`, or a folder of kept blocks)")
    if any(n.startswith("s") and n.endswith(".json") for n in os.listdir(path)):
        return KeptBlocks(path)
    return StudyFolder(path)


def keep_block(study, dest):
    """Writes dest/sS.json from a finished one-seed study: its round robins' pairings and each run's
    controls summary. Refuses, in one line, a block with another seed count or a missing piece."""
    runs = {dt: sorted(d for d in (os.listdir(os.path.join(study, f"dt{dt}"))
                                   if os.path.isdir(os.path.join(study, f"dt{dt}")) else []) if variant_of(d))
            for dt in INTERVALS}
    seeds = {r.rsplit("_s", 1)[1] for dt in INTERVALS for r in runs[dt]}
    if len(seeds) != 1:
        sys.exit(f"{study}: a block is one seed's study; found seeds {sorted(seeds) or 'none'}")
    intervals = {}
    for dt in INTERVALS:
        path = os.path.join(study, f"dt{dt}", "tournament", "pairings.csv")
        if not os.path.exists(os.path.join(study, f"dt{dt}", "tournament", "done.txt")):
            sys.exit(f"{study}/dt{dt}/tournament: the round robin has not finished; run the study on")
        with open(path) as f:
            pairings = [[r["row_entry"], r["column_entry"], float(r["winrate"])] for r in csv.DictReader(f)
                        if variant_of(r["row_entry"]) and variant_of(r["column_entry"])]
        controls = {run: read_controls(study, dt, run) for run in runs[dt]}
        for run, got in controls.items():
            if got is None:
                sys.exit(f"{study}/dt{dt}/controls/{run}: no done.txt; race the run's controls first")
        intervals[str(dt)] = dict(pairings=pairings, controls=controls)
    seed = seeds.pop()
    block = dict(seed=int(seed), intervals=intervals, **kept_json.provenance())
    kept_json.write(os.path.join(dest, f"s{seed}.json"), block)


def beats(reps):
    """The reading of "u beats v" from the bootstrap replicates of M(u, v), by the rule's δ."""
    lo, hi = percentiles(reps)
    if lo > 0.5:
        word = "yes" if hi >= 0.5 + DELTA else "yes, by less than δ"
    elif hi < 0.5 + DELTA:
        word = "no, reversed" if hi < 0.5 else "no"
    else:
        word = "?"
    return word, lo, hi


def all_of(words):
    """Three comparisons that must all be "yes": the intersection-union rule."""
    if all(x.startswith("yes") for x in words):
        return HOLDS
    if any(x.startswith("no") for x in words):
        return NOT
    return CANNOT


def read_controls(study, dt, run):
    """{vs_center, vs_random, block_diff_sum, center_blocks_sum, races} of RUN's controls tournament
    (block sums over its races against RUN@center), or None if it has not finished."""
    folder = os.path.join(study, f"dt{dt}", "controls", run)
    if not os.path.exists(os.path.join(folder, "done.txt")):
        return None
    wins = {}
    with open(os.path.join(folder, "pairings.csv")) as f:
        for r in csv.DictReader(f):
            a, b, x = r["row_entry"], r["column_entry"], float(r["winrate"])
            wins[(a, b)] = x
            wins[(b, a)] = 1.0 - x
    center, random_ = run + "@center", run + "@random"
    out = dict(vs_center=wins[(run, center)], vs_random=wins[(run, random_)], block_diff_sum=0,
               center_blocks_sum=0, races=0)
    with open(os.path.join(folder, "races.csv")) as f:
        for r in csv.DictReader(f):
            sides = {r["blue"]: int(r["blue_blocks"]), r["red"]: int(r["red_blocks"])}
            if set(sides) == {run, center}:
                out["block_diff_sum"] += sides[run] - sides[center]
                out["center_blocks_sum"] += sides[center]
                out["races"] += 1
    return out


def mean_verdict(values_by_variant, label, lo_bar, hi_bar):
    """Pooled mean (bootstrap stratified by variant) and per variant: holds if lo > lo_bar, does not
    hold if hi < hi_bar. Returns rows (what, n, mean, lo, hi, verdict)."""
    rows = []
    pooled = [x for v in VARIANTS for x in values_by_variant.get(v, [])]
    if not pooled:
        return rows
    groups = [values_by_variant[v] for v in VARIANTS if values_by_variant.get(v)]

    def verdict(lo, hi):
        return HOLDS if lo > lo_bar else (NOT if hi < hi_bar else CANNOT)

    r = rng(label + ":pooled")
    reps = []
    for _ in range(REPS):
        s = n = 0
        for g in groups:
            for _ in g:
                s += g[r.randrange(len(g))]
                n += 1
        reps.append(s / n)
    lo, hi = percentiles(reps)
    rows.append(("pooled", len(pooled), sum(pooled) / len(pooled), lo, hi, verdict(lo, hi)))
    for v in VARIANTS:
        g = values_by_variant.get(v, [])
        if not g:
            continue
        r = rng(label + ":" + v)
        reps = [sum(g[r.randrange(len(g))] for _ in g) / len(g) for _ in range(REPS)]
        lo, hi = percentiles(reps)
        rows.append((v, len(g), sum(g) / len(g), lo, hi, verdict(lo, hi)))
    return rows


def trim_mean(xs):
    """The interquartile mean as rliable computes it: floor(n / 4) values cut from each end."""
    x = sorted(xs)
    k = len(x) // 4
    x = x[k:len(x) - k]
    return sum(x) / len(x)


def panel_values(w, runs, label):
    """Fig. 3's panels from same-seed pairings, as numbers: {"variants": {u: {runs, total_mean,
    total_std, iqm, iqm_lo, iqm_hi}}, "matrix": {(u, v): mean winrate of u_sS against v_sS}}. A
    run's total winrate is its mean over the other variants of its seed; the IQM is over its
    pairing winrates, with a stratified bootstrap CI (runs resampled within each opposing variant)."""
    seed = lambda run: run.rsplit("_s", 1)[1]
    by_seed = {v: {seed(r): r for r in runs[v]} for v in VARIANTS}
    variants, matrix = {}, {}
    for u in VARIANTS:
        others = [v for v in VARIANTS if v != u]
        seeds = sorted(sd for sd in by_seed[u] if all(sd in by_seed[v] for v in others))
        if not seeds:
            continue
        scores = {v: [w[(by_seed[u][sd], by_seed[v][sd])] for sd in seeds] for v in others}
        totals = [sum(scores[v][k] for v in others) / len(others) for k in range(len(seeds))]
        m = sum(totals) / len(totals)
        sd_ = (sum((t - m) ** 2 for t in totals) / (len(totals) - 1)) ** 0.5 if len(totals) > 1 else 0.0
        point = trim_mean([x for v in others for x in scores[v]])
        r = rng(f"{label}:iqm:{u}")
        reps = [trim_mean([scores[v][r.randrange(len(seeds))] for v in others for _ in seeds]) for _ in range(REPS)]
        lo, hi = percentiles(reps)
        variants[u] = dict(runs=len(seeds), total_mean=m, total_std=sd_, iqm=point, iqm_lo=lo, iqm_hi=hi)
    for u in VARIANTS:
        for v in VARIANTS:
            pairs = [w[(by_seed[u][sd], by_seed[v][sd])] for sd in by_seed[u] if sd in by_seed[v]] if u != v else []
            if pairs:
                matrix[(u, v)] = sum(pairs) / len(pairs)
    return dict(variants=variants, matrix=matrix)


def paper_panels(w, runs, label):
    """panel_values as Markdown (they decide nothing)."""
    p = panel_values(w, runs, label)
    lines = ["| variant | runs | total winrate, mean ± std | IQM of pairing winrates [95 % CI] |",
             "|---|---|---|---|"]
    for u, x in p["variants"].items():
        lines.append(f"| {u} | {x['runs']} | {x['total_mean']:.3f} ± {x['total_std']:.3f} | "
                     f"{x['iqm']:.3f} [{x['iqm_lo']:.3f}, {x['iqm_hi']:.3f}] |")
    lines += ["", "| row beats column | " + " | ".join(VARIANTS) + " |", "|---|" + "---|" * len(VARIANTS)]
    for u in VARIANTS:
        cells = [f"{p['matrix'][(u, v)]:.3f}" if (u, v) in p["matrix"] else "" for v in VARIANTS]
        lines.append(f"| {u} | " + " | ".join(cells) + " |")
    return lines


def pilot_verdicts(source, tag):
    """Per claim and interval: the verdict, and the Markdown lines that support it."""
    out, lines, m_d3d2 = {}, [], {}
    for dt in INTERVALS:
        w = source.round_robin(dt)
        lines.append(f"\n### Pilot {tag}, Δt_HL = {dt} s\n")
        if w is None:
            lines.append("round robin not raced yet: (a), (b) missing")
        else:
            runs = runs_by_variant(w)
            lines.append("runs per variant: " + ", ".join(f"{v} {len(runs[v])}" for v in VARIANTS)
                         + ("; M(u, v) over same-seed pairings, seeds resampled" if source.blocked else "") + "\n")
            lines.append("| u beats v | M(u, v) | 95 % CI | reading |\n|---|---|---|---|")
            word = {}
            pairs = [("es_d3", "es"), ("es_d3", "es_d1"), ("es_d3", "es_d2"), ("es_d2", "es_d1"), ("es_d1", "es"),
                     ("es_d2", "es")]
            for u, v in pairs:
                if not runs[u] or not runs[v]:
                    word[(u, v)] = "?"
                    continue
                point, reps = source.match(w, runs[u], runs[v], tag, dt, u, v)
                word[(u, v)], lo, hi = beats(reps)
                if (u, v) == ("es_d3", "es_d2"):
                    m_d3d2[dt] = reps
                lines.append(f"| {u} > {v} | {point:.3f} | [{lo:.3f}, {hi:.3f}] | {word[(u, v)]} |")
            if source.blocked:
                lines += ["", "The paper's panels (deciding nothing):", ""] + paper_panels(w, runs, f"{tag}:{dt}") + [""]
            out[("a", dt)] = all_of([word[("es_d3", v)] for v in ("es", "es_d1", "es_d2")])
            out[("b", dt)] = all_of([word[("es_d3", "es_d2")], word[("es_d2", "es_d1")], word[("es_d1", "es")]])
        c_center, c_random, b_diff = {}, {}, {}
        center_sum = center_races = missing = 0
        controls = source.controls(dt)
        for run in sorted(controls):
            v, got = variant_of(run), controls[run]
            if v is None:
                continue
            if got is None:
                missing += 1
                continue
            c_center.setdefault(v, []).append(got["vs_center"])
            c_random.setdefault(v, []).append(got["vs_random"])
            b_diff.setdefault(v, []).append(got["block_diff_sum"] / got["races"])
            center_sum += got["center_blocks_sum"]
            center_races += got["races"]
        if missing:
            lines.append(f"\ncontrols tournaments missing for {missing} runs: (c), (d) read from the others")
        for claim, values, lo_bar, hi_bar, what in (
                ("c", c_center, 0.5, 0.5 + DELTA, "winrate against its own @center"),
                ("c'", c_random, 0.5, 0.5 + DELTA, "winrate against its own @random")):
            rows = mean_verdict(values, f"{tag}:{dt}:{claim}", lo_bar, hi_bar)
            if rows:
                out[(claim, dt)] = rows[0][5]
                lines.append(f"\n({claim}) {what}\n\n| runs | n | mean | 95 % CI | verdict |\n|---|---|---|---|---|")
                lines += [f"| {r[0]} | {r[1]} | {r[2]:.3f} | [{r[3]:.3f}, {r[4]:.3f}] | {r[5]} |" for r in rows]
        if center_races:
            beta = center_sum / center_races
            rows = mean_verdict(b_diff, f"{tag}:{dt}:d", 0.0, 0.10 * beta)
            out[("d", dt)] = rows[0][5]
            lines.append(f"\n(d) blocks per race minus its @center's (β = {beta:.3f}, δ_b = {0.1 * beta:.3f})\n\n"
                         "| runs | n | mean | 95 % CI | verdict |\n|---|---|---|---|---|")
            lines += [f"| {r[0]} | {r[1]} | {r[2]:+.3f} | [{r[3]:+.3f}, {r[4]:+.3f}] | {r[5]} |" for r in rows]
    if ("b", 20) in out:
        out[("e1", 20)] = out[("b", 20)]
    if 8 in m_d3d2 and 20 in m_d3d2:
        diff = [(a - 0.5) - (b - 0.5) for a, b in zip(m_d3d2[8], m_d3d2[20])]
        lo, hi = percentiles(diff)
        e2 = HOLDS if lo > 0 else (NOT if hi < DELTA else CANNOT)
        out[("e2", 20)] = e2
        lines.append(f"\n(e2) ES+D2's shortfall against ES+D3, 8 s minus 20 s: 95 % CI [{lo:+.3f}, {hi:+.3f}]: {e2}")
        e1 = out.get(("e1", 20), CANNOT)
        out[("e", 20)] = HOLDS if (e1 == HOLDS and e2 == HOLDS) else (NOT if NOT in (e1, e2) else CANNOT)
    return out, lines


def across(a, b):
    if a is None or b is None:
        return "pilot A only: " + (a or b or "missing") if (a or b) else "missing"
    if a == HOLDS and b == HOLDS:
        return HOLDS
    if NOT in (a, b):
        return NOT + (" (depends on the pilot)" if HOLDS in (a, b) else "")
    return CANNOT


def main(argv):
    if argv[1:2] == ["--keep-block"]:
        if len(argv) != 4:
            sys.exit("usage: study_verdicts.py --keep-block BLOCK_STUDY KEEP_DIR")
        return keep_block(argv[2], argv[3])
    if len(argv) not in (2, 3):
        sys.exit("usage: study_verdicts.py STUDY_A [STUDY_B]")
    studies = argv[1:]
    results, text = [], []
    sources = [open_study(s) for s in studies]
    for tag, src in zip("AB", sources):
        out, lines = pilot_verdicts(src, tag)
        results.append(out)
        text += lines
    claims = [("a", "ES+D3 is the best variant"), ("b", "the order D3 > D2 > D1 > ES"),
              ("c", "the trained HL beats its own center line"), ("c'", "... and its random goals"),
              ("d", "it blocks more than its center line"), ("e", "the 20 s horizon as the paper says")]
    print("## Verdicts\n")
    for tag, src in zip("AB", sources):
        if src.blocked and len(src.blocks) < PLANNED_BLOCKS:
            print(f"**Provisional**: pilot {tag} has {len(src.blocks)} of the {PLANNED_BLOCKS} pre-registered blocks; "
                  "notebook 72 draws no verdict before all are in.\n")
    print("| claim | Δt_HL | " + " | ".join(f"pilot {t}" for t in "AB"[:len(studies)]) + " | verdict |")
    print("|---|---|" + "---|" * len(studies) + "---|")
    for key, what in claims:
        for dt in ([20] if key == "e" else INTERVALS):
            per = [r.get((key, dt)) for r in results]
            verdict = across(per[0], per[1]) if len(per) == 2 else ("pilot A only: " + (per[0] or "missing"))
            print(f"| ({key}) {what} | {dt} s | " + " | ".join(p or "missing" for p in per) + f" | {verdict} |")
    print("\n".join(text))


if __name__ == "__main__":
    main(sys.argv)
