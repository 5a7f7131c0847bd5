#!/usr/bin/env python3
"""The figure of a blocked Fig. 3 study (notebook 72): per pilot and HL interval, a row of four
panels drawn from the kept blocks alone.

    experiments/scripts/study_figures.py OUT_DIR KEEP_A [KEEP_B]

KEEP_x is a folder of sS.json blocks (`study_verdicts.py --keep-block`). Writes into OUT_DIR:
  fig3_panels.csv   per pilot, interval and variant: runs, total winrate mean and std, IQM of
                    pairing winrates with its 95 % CI, the mean winrate against the run's own
                    @center and @random with 95 % CIs (the numbers study_verdicts.py prints, from
                    the same functions and bootstrap labels)
  fig3_matrix.csv   per pilot and interval, M(u, v): the mean winrate of u_sS against v_sS
  fig3.gp, fig3.png the gnuplot script and its 1600-pixel-wide figure: (1) total winrate, mean ± std
                    (Fig. 3 panels 1 and 4), (2) IQM with its CI (panels 2 and 5), (3) the
                    variant-vs-variant matrix (panels 3 and 6), (4) each variant against its own
                    controls, with the 0.5 and 0.55 (0.5 + δ) lines of the decision rules.
Without gnuplot the CSV files and the script are written and the exit status is 1. Standard
library only.
"""
import csv
import os
import shutil
import subprocess
import sys

sys.path.insert(0, os.path.dirname(os.path.abspath(__file__)))
import study_verdicts as sv  # noqa: E402

PANEL_COLUMNS = ["pilot", "dt_hl_s", "variant", "runs", "total_mean", "total_std", "iqm", "iqm_lo", "iqm_hi",
                 "vs_center", "vs_center_lo", "vs_center_hi", "vs_random", "vs_random_lo", "vs_random_hi"]


def controls_by_variant(source, dt):
    """{variant: ([vs_center per run], [vs_random per run])} from the kept controls."""
    center, random_ = {}, {}
    for run, got in sorted(source.controls(dt).items()):
        v = sv.variant_of(run)
        if v is None or got is None:
            continue
        center.setdefault(v, []).append(got["vs_center"])
        random_.setdefault(v, []).append(got["vs_random"])
    return center, random_


def pilot_rows(source, tag):
    """The panel rows and matrix rows of one pilot, both intervals."""
    panels, matrix = [], []
    for dt in sv.INTERVALS:
        w = source.round_robin(dt)
        if w is None:
            continue
        values = sv.panel_values(w, sv.runs_by_variant(w), f"{tag}:{dt}")
        center, random_ = controls_by_variant(source, dt)
        # The labels study_verdicts uses for (c) and (c'), so both print the same intervals.
        c_rows = {r[0]: r for r in sv.mean_verdict(center, f"{tag}:{dt}:c", 0.5, 0.5 + sv.DELTA)}
        r_rows = {r[0]: r for r in sv.mean_verdict(random_, f"{tag}:{dt}:c'", 0.5, 0.5 + sv.DELTA)}
        for v in sv.VARIANTS:
            x = values["variants"].get(v)
            if x is None:
                continue
            c = c_rows.get(v, (v, 0, float("nan"), float("nan"), float("nan")))
            r = r_rows.get(v, (v, 0, float("nan"), float("nan"), float("nan")))
            panels.append([tag, dt, v, x["runs"], x["total_mean"], x["total_std"], x["iqm"], x["iqm_lo"],
                           x["iqm_hi"], c[2], c[3], c[4], r[2], r[3], r[4]])
        for i, u in enumerate(sv.VARIANTS):
            for j, v in enumerate(sv.VARIANTS):
                if (u, v) in values["matrix"]:
                    matrix.append([tag, dt, i, j, u, v, values["matrix"][(u, v)]])
    return panels, matrix


def write_csv(path, header, rows):
    with open(path + ".tmp", "w", newline="") as f:
        out = csv.writer(f)
        out.writerow(header)
        for r in rows:
            out.writerow([f"{x:.4f}" if isinstance(x, float) else x for x in r])
    os.replace(path + ".tmp", path)


def panel_block(tag, dt, row_index, n_rows):
    """The gnuplot lines of one (pilot, interval) row: four panels."""
    sel = f'(strcol(1) eq "{tag}" && $2 == {dt})'
    title = f"pilot {tag}, {dt} s"
    xt = 'set xtics ("es" 0, "es\\\\_d1" 1, "es\\\\_d2" 2, "es\\\\_d3" 3); set xrange [-0.6:3.6]'
    vix = '(($3 eq "es") ? 0 : ($3 eq "es_d1") ? 1 : ($3 eq "es_d2") ? 2 : 3)'
    vix = vix.replace("$3", "strcol(3)")
    return [
        f"# --- pilot {tag}, dt {dt} s (row {row_index + 1} of {n_rows})",
        xt, "set yrange [0.3:0.8]", "set grid ytics",
        f'set title "{title}: total winrate, mean ± std"',
        f"plot 'fig3_panels.csv' every ::1 using ({sel} ? {vix} : 1/0):5:6 with yerrorbars pt 7 lc rgb '#1f77b4' "
        "notitle, 0.5 with lines dt 2 lc rgb 'gray' notitle",
        f'set title "{title}: IQM of pairing winrates, 95 % CI"',
        f"plot 'fig3_panels.csv' every ::1 using ({sel} ? {vix} : 1/0):7:8:9 with yerrorbars pt 7 "
        "lc rgb '#2ca02c' notitle, 0.5 with lines dt 2 lc rgb 'gray' notitle",
        'set title "' + title + ': row beats column, same-seed mean"',
        "unset grid", "set xrange [-0.5:3.5]; set yrange [3.5:-0.5]",
        'set ytics ("es" 0, "es\\\\_d1" 1, "es\\\\_d2" 2, "es\\\\_d3" 3)',
        "set cbrange [0.3:0.7]; set palette defined (0 '#b2182b', 0.5 'white', 1 '#2166ac')",
        f"plot 'fig3_matrix.csv' every ::1 using ({sel} ? $4 : 1/0):3:(0.5):(0.5):7 with boxxyerror "
        "fs solid border lc rgb 'gray' lc palette notitle, "
        f"'' every ::1 using ({sel} ? $4 : 1/0):3:(sprintf('%.2f', $7)) with labels notitle",
        "set ytics auto; unset cbrange", xt, "set yrange [0.3:1.0]", "set grid ytics",
        f'set title "{title}: against its own controls, 95 % CI"',
        f"plot 'fig3_panels.csv' every ::1 using ({sel} ? {vix} - 0.1 : 1/0):10:11:12 with yerrorbars pt 7 "
        f"lc rgb '#d62728' title 'vs its center line (@center)' noenhanced, '' every ::1 using ({sel} ? {vix} + 0.1 : 1/0):13:14:15 "
        "with yerrorbars pt 5 lc rgb '#9467bd' title 'vs its random goals (@random)' noenhanced, 0.5 with lines dt 2 lc rgb 'gray' notitle, "
        "0.5 + 0.05 with lines dt 3 lc rgb 'gray' notitle",
    ]


def gnuplot_script(rows):
    lines = ["# Written by experiments/scripts/study_figures.py; `gnuplot fig3.gp` in this folder redraws fig3.png.",
             f"set terminal pngcairo size 1600,{360 * len(rows)} font 'Sans,10'",
             "set output 'fig3.png'", "set datafile separator ','",
             f"set multiplot layout {len(rows)},4", "set key top left"]
    for k, (tag, dt) in enumerate(rows):
        lines += panel_block(tag, dt, k, len(rows))
    lines += ["unset multiplot"]
    return "\n".join(lines) + "\n"


def main(argv):
    if len(argv) not in (3, 4):
        sys.exit("usage: study_figures.py OUT_DIR KEEP_A [KEEP_B]")
    out = argv[1]
    panels, matrix = [], []
    for tag, path in zip("AB", argv[2:]):
        source = sv.open_study(path)
        if not source.blocked:
            sys.exit(f"{path}: not a folder of kept blocks (sS.json from study_verdicts.py --keep-block)")
        p, m = pilot_rows(source, tag)
        panels += p
        matrix += m
    if not panels:
        sys.exit("no round robin in the kept blocks: nothing to draw")
    os.makedirs(out, exist_ok=True)
    write_csv(os.path.join(out, "fig3_panels.csv"), PANEL_COLUMNS, panels)
    write_csv(os.path.join(out, "fig3_matrix.csv"), ["pilot", "dt_hl_s", "row", "column", "row_variant",
                                                      "column_variant", "winrate"], matrix)
    rows = sorted({(r[0], r[1]) for r in panels})
    with open(os.path.join(out, "fig3.gp"), "w") as f:
        f.write(gnuplot_script(rows))
    if shutil.which("gnuplot") is None:
        print(f"gnuplot not found (install gnuplot-nox); data and {out}/fig3.gp written", file=sys.stderr)
        return 1
    done = subprocess.run(["gnuplot", "fig3.gp"], cwd=out, capture_output=True, text=True)
    if done.returncode != 0:
        sys.exit(f"gnuplot failed on {out}/fig3.gp: {done.stderr.strip().splitlines()[-1:]}")
    print(f"written: {out}/fig3_panels.csv, fig3_matrix.csv, fig3.gp, fig3.png")
    return 0


if __name__ == "__main__":
    sys.exit(main(sys.argv))
