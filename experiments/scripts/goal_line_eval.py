#!/usr/bin/env python3
"""Notebook 85's rule: the same runs raced against the tuned autopilot with their goals on the
racing line (`tournament --set race.goal_line_frac=F`) and without, paired by seed.

    experiments/scripts/goal_line_eval.py WITHOUT_DIR WITH_DIR [--json FILE]

WITHOUT_DIR holds per seed S the tournament `t_sS`, WITH_DIR the tournament `line_sS`, each of
`tournament --runs sS --no-untrained --with-autopilot --controls` (a seed counts when both have
done.txt). Per seed and entry (`sS@center`: the middle bin, on the line when there is one; `sS`:
its trained high level) against `autopilot`: the winrate (Wilson 95 %), the winrate in clean
races, and the entry's aircraft lost per race by cause; then over seeds, with minus without,
the mean and a bootstrap 95 % interval over seeds (10 000 resamples, random seed 85), and the
rule: the primary (`@center`'s winrate) above 0 and the guard (its tube losses) under 0.1.
Standard library.
"""
import csv
import json
import os
import sys

sys.path.insert(0, os.path.dirname(os.path.abspath(__file__)))
from pilot_seeds_table import CAUSES, boot, head_to_head, wilson  # noqa: E402

ENTRIES = ("@center", "")


def seeds(without, with_):
    out = []
    for name in sorted(os.listdir(with_)):
        if name.startswith("line_s") and name[6:].isdigit():
            s = int(name[6:])
            if all(os.path.exists(os.path.join(d, "done.txt"))
                   for d in (os.path.join(with_, name), os.path.join(without, f"t_s{s}"))):
                out.append(s)
    return sorted(out)


def measure(folder, entry):
    with open(os.path.join(folder, "races.csv"), newline="") as f:
        rows = list(csv.DictReader(f))
    h = head_to_head(rows, entry, "autopilot")
    if h["n"] == 0:
        raise SystemExit(f"{folder}/races.csv: no races of {entry} against autopilot; race it with --with-autopilot")
    return {"winrate": h["w"] / h["n"], "races": h["n"], "wins": h["w"],
            "clean_winrate": h["clean_w"] / h["clean_n"] if h["clean_n"] else float("nan"),
            "lost": h["lost"], "lost_per_race": sum(h["lost"].values())}


def main(argv):
    if len(argv) not in (2, 4) or (len(argv) == 4 and argv[2] != "--json"):
        raise SystemExit("usage: experiments/scripts/goal_line_eval.py WITHOUT_DIR WITH_DIR [--json FILE]")
    without, with_ = argv[0], argv[1]
    for d in (without, with_):
        if not os.path.isdir(d):
            raise SystemExit(f"{d}: no such folder")
    ss = seeds(without, with_)
    if not ss:
        raise SystemExit(f"{with_}: no seed has both line_sS/done.txt and {without}/t_sS/done.txt")
    table = {}
    for s in ss:
        for e in ENTRIES:
            name = f"s{s}{e}"
            table[name] = {"without": measure(os.path.join(without, f"t_s{s}"), name),
                           "with": measure(os.path.join(with_, f"line_s{s}"), name)}
    print(f"{len(ss)} seeds: {ss}")
    print("| entry | vs autopilot, without | with the line | clean, without / with | lost per race, without / with | tube, without / with |")
    print("|---|---|---|---|---|---|")
    for name, m in table.items():
        a, b = m["without"], m["with"]
        lo, hi = wilson(b["wins"], b["races"])
        print(f"| {name} | {a['winrate']:.3f} | {b['winrate']:.3f} [{lo:.3f}, {hi:.3f}] | "
              f"{a['clean_winrate']:.3f} / {b['clean_winrate']:.3f} | {a['lost_per_race']:.3f} / {b['lost_per_race']:.3f} | "
              f"{a['lost']['tube']:.3f} / {b['lost']['tube']:.3f} |")
    summary = {}
    for e in ENTRIES:
        label = "sS" + e
        diffs = {
            "winrate": [table[f"s{s}{e}"]["with"]["winrate"] - table[f"s{s}{e}"]["without"]["winrate"] for s in ss],
            "clean_winrate": [table[f"s{s}{e}"]["with"]["clean_winrate"] - table[f"s{s}{e}"]["without"]["clean_winrate"]
                              for s in ss],
            "lost_per_race": [table[f"s{s}{e}"]["with"]["lost_per_race"] - table[f"s{s}{e}"]["without"]["lost_per_race"]
                              for s in ss],
        }
        for c in CAUSES:
            diffs["lost_" + c] = [table[f"s{s}{e}"]["with"]["lost"][c] - table[f"s{s}{e}"]["without"]["lost"][c] for s in ss]
        means = {k: sum(v) / len(v) for k, v in diffs.items()}
        cis = {k: boot(v, seed=85) for k, v in diffs.items()}
        bar = sum(wilson(table[f"s{s}{e}"]["with"]["wins"], table[f"s{s}{e}"]["with"]["races"])[0] > 0.6 for s in ss)
        summary[label] = {"mean_difference": means, "ci95": cis, "seeds_over_bar_with_line": bar,
                          "mean_with": sum(table[f"s{s}{e}"]["with"]["winrate"] for s in ss) / len(ss),
                          "mean_without": sum(table[f"s{s}{e}"]["without"]["winrate"] for s in ss) / len(ss)}
        print(f"\n{label} against the autopilot: mean {summary[label]['mean_without']:.3f} without, "
              f"{summary[label]['mean_with']:.3f} with; seeds over the bar with the line: {bar} of {len(ss)}")
        for k in ("winrate", "clean_winrate", "lost_per_race", "lost_tube", "lost_collision", "lost_team_collision",
                  "lost_envelope"):
            print(f"  with - without, {k}: {means[k]:+.3f} [{cis[k][0]:+.3f}, {cis[k][1]:+.3f}]")
    c = summary["sS@center"]
    primary, guard = c["ci95"]["winrate"][0] > 0.0, c["ci95"]["lost_tube"][1] < 0.1
    verdict = ("keeps the line's margin" if primary and guard else
               "the margin without the guard: the losses are the next question" if primary else
               "does not keep the line's margin")
    print(f"\nrule (notebook 85): primary {'above 0' if primary else 'not above 0'}, guard "
          f"{'holds' if guard else 'fails'}: the learned pilot {verdict}")
    if len(argv) == 4:
        with open(argv[3], "w") as f:
            json.dump({"seeds": ss, "per_entry": table, "summary": summary, "verdict": verdict}, f, indent=1)


if __name__ == "__main__":
    main(sys.argv[1:])
