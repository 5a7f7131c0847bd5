#!/usr/bin/env python3
"""Notebook 66's verdicts: the paper's high-level claims from a Fig. 3 study on one frozen pilot.

    scripts/study_verdicts.py STUDY_A [STUDY_B]

STUDY_x is a `study --out` folder of configs/study_pilot.yaml: per interval dtD (8, 20) the runs
`dtD/VARIANT_sS`, the round robin `dtD/tournament/pairings.csv`, and per run its controls
tournament `dtD/controls/VARIANT_sS/` (pairings.csv, races.csv). Implements the decision rules of
docs/notebook/66 as written there, before any run: per claim, pilot and interval "holds", "does
not hold" or "cannot tell at this power"; with two studies, the cross-pilot verdict. Missing
pieces (an interval not raced yet, controls not run) are reported as missing, never guessed.
Bootstraps: 10 000 replicates, random seed 50 (Python's Random, seeded with "50:" + what is
resampled, so each quantity's replicates do not depend on which others were computed). Standard
library only.
"""
import csv
import os
import random
import sys

VARIANTS = ["es", "es_d1", "es_d2", "es_d3"]
INTERVALS = [8, 20]
DELTA = 0.05  # the smallest difference of pairing winrate the study resolves
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


def beats(point, reps):
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
    """(winrate vs RUN@center, vs RUN@random, per-race block differences, @center's blocks) or None."""
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
    diffs, center_blocks = [], []
    with open(os.path.join(folder, "races.csv")) as f:
        for r in csv.DictReader(f):
            sides = {r["blue"]: int(r["blue_blocks"]), r["red"]: int(r["red_blocks"])}
            if set(sides) == {run, center}:
                diffs.append(sides[run] - sides[center])
                center_blocks.append(sides[center])
    return wins[(run, center)], wins[(run, random_)], diffs, center_blocks


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


def pilot_verdicts(study, tag):
    """Per claim and interval: the verdict, and the Markdown lines that support it."""
    out, lines, m_d3d2 = {}, [], {}
    for dt in INTERVALS:
        w = round_robin(study, dt)
        lines.append(f"\n### Pilot {tag}, Δt_HL = {dt} s\n")
        if w is None:
            lines.append("round robin not raced yet: (a), (b) missing")
        else:
            runs = runs_by_variant(w)
            lines.append("runs per variant: " + ", ".join(f"{v} {len(runs[v])}" for v in VARIANTS) + "\n")
            lines.append("| u beats v | M(u, v) | 95 % CI | reading |\n|---|---|---|---|")
            word = {}
            pairs = [("es_d3", "es"), ("es_d3", "es_d1"), ("es_d3", "es_d2"), ("es_d2", "es_d1"), ("es_d1", "es"),
                     ("es_d2", "es")]
            for u, v in pairs:
                if not runs[u] or not runs[v]:
                    word[(u, v)] = "?"
                    continue
                point, reps = match_replicates(w, runs[u], runs[v], f"{tag}:{dt}:{u}:{v}")
                word[(u, v)], lo, hi = beats(point, reps)
                if (u, v) == ("es_d3", "es_d2"):
                    m_d3d2[dt] = reps
                lines.append(f"| {u} > {v} | {point:.3f} | [{lo:.3f}, {hi:.3f}] | {word[(u, v)]} |")
            out[("a", dt)] = all_of([word[("es_d3", v)] for v in ("es", "es_d1", "es_d2")])
            out[("b", dt)] = all_of([word[("es_d3", "es_d2")], word[("es_d2", "es_d1")], word[("es_d1", "es")]])
        c_center, c_random, b_diff, beta_all = {}, {}, {}, []
        missing = 0
        for v in VARIANTS:
            for d in sorted(os.listdir(os.path.join(study, f"dt{dt}"))) if os.path.isdir(os.path.join(study, f"dt{dt}")) else []:
                if variant_of(d) != v:
                    continue
                got = read_controls(study, dt, d)
                if got is None:
                    missing += 1
                    continue
                wc, wr, diffs, cb = got
                c_center.setdefault(v, []).append(wc)
                c_random.setdefault(v, []).append(wr)
                b_diff.setdefault(v, []).append(sum(diffs) / len(diffs))
                beta_all += cb
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
        if beta_all:
            beta = sum(beta_all) / len(beta_all)
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
    if len(argv) not in (2, 3):
        sys.exit("usage: study_verdicts.py STUDY_A [STUDY_B]")
    studies = argv[1:]
    results, text = [], []
    for tag, s in zip("AB", studies):
        if not os.path.isdir(s):
            sys.exit(f"{s}: not a study folder (give the --out folder of `f16race study`)")
        out, lines = pilot_verdicts(s, tag)
        results.append(out)
        text += lines
    claims = [("a", "ES+D3 is the best variant"), ("b", "the order D3 > D2 > D1 > ES"),
              ("c", "the trained HL beats its own center line"), ("c'", "... and its random goals"),
              ("d", "it blocks more than its center line"), ("e", "the 20 s horizon as the paper says")]
    print("## Verdicts\n")
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
