#!/usr/bin/env bash
# shipped_team (issue 52): examples/trained_team/ still loads with this build in replay (with
# --html), tournament, export and Python's f16race.load_policy, and still races as it did when it
# was shipped: its winrate against AeroBench's autopilot in a short tournament lies within
# `tolerance` of the one provenance.md records (a change to the race or the networks' inputs moves
# it), and the recorded one's Wilson interval lies above 0.5. When it no longer loads or races differently, says how to retrain and reship it.
# usage: shipped_team.sh F16RACE SOURCE_DIR WORK_DIR [PYTHON PYTHONPATH]  (the last two: the module's tests)
set -uo pipefail
bin=$1 src=$2 work=$3 python=${4:-} pypath=${5:-}
team=$src/examples/trained_team
tolerance=0.2   # vs the recorded winrate: ~2.5 standard errors of a 64-race winrate
races=64
rm -rf "$work" && mkdir -p "$work"

if [ ! -f "$team/config.yaml" ]; then
  echo "FAIL: $team holds no trained run: train one (f16race train --config configs/default.yaml --run runs/team)" \
       "and ship it with scripts/ship_team.sh runs/team \"THE TRAIN COMMAND\" (docs/viewer.md, \"The shipped team\")"
  exit 1
fi
retrain=$(sed -n 's/^- command: `\(.*\)`$/\1/p' "$team/provenance.md" 2>/dev/null | head -1)
unloadable() {
  echo "FAIL: the shipped team no longer loads with this build: retrain with \`${retrain:-f16race train --config configs/default.yaml --run runs/team}\`" \
       "and run scripts/ship_team.sh RUN (docs/viewer.md, \"The shipped team\"). $1 said:"
  sed 's/^/  /' "$work/out.txt"
  exit 1
}

"$bin" replay --run "$team" --opponent autopilot --out "$work/replay" --html "$work/race.html" >"$work/out.txt" 2>&1 ||
  unloadable "replay"
[ -s "$work/race.html" ] || { echo "FAIL: replay --html wrote no page"; exit 1; }
echo "ok    replay --html: $(head -1 "$work/out.txt")"
"$bin" export --run "$team" --out "$work/export" >"$work/out.txt" 2>&1 || unloadable "export"
echo "ok    export: $(sed -n 3p "$work/out.txt" | sed 's/^ *//')"
if [ -n "$python" ]; then
  PYTHONPATH=$pypath "$python" - "$team" >"$work/out.txt" 2>&1 <<'PY' || unloadable "f16race.load_policy"
import sys
import f16race
import numpy as np
p = f16race.load_policy(sys.argv[1])
env = p.make_env(n_env=2, seed=1)  # the shipped config, so the observations match the networks
obs, _ = env.reset()
env.set_hl_actions(p.hl_bins(obs))
actions = p.act(obs)
assert actions.shape == (2, 2 * env.team_size, 3) and np.isfinite(actions).all(), actions.shape
obs, *_ = env.step(actions)
print(f"{p!r} flew a step of 2 races ({env.team_size} vs {env.team_size}) with the shipped config")
PY
  echo "ok    f16race.load_policy: $(tail -1 "$work/out.txt")"
else
  echo "note  f16race.load_policy not checked: the Python module is not built (F16RACE_PYTHON off)"
fi
"$bin" tournament --runs "$team" --with-autopilot --no-untrained --races "$races" --out "$work/tour" >"$work/out.txt" 2>&1 ||
  unloadable "tournament"
winrate=$(awk -F, '$7 == "trained_team" && $8 == "autopilot" { print $3 }' "$work/tour/pairings.csv")
[ -n "$winrate" ] || { echo "FAIL: no trained_team vs autopilot pairing in $work/tour/pairings.csv"; exit 1; }
recorded=$(sed -n 's/^| trained_team vs autopilot | [0-9]* | \([0-9.]*\) .*/\1/p' "$team/provenance.md" | head -1)
[ -n "$recorded" ] || { echo "FAIL: $team/provenance.md records no winrate against the autopilot (reship with scripts/ship_team.sh)"; exit 1; }
# The recorded figure (hundreds of races) is the evidence that the team beats the autopilot.
low=$(sed -n 's/^| trained_team vs autopilot | [0-9]* | [0-9.]* \[\([0-9.]*\),.*/\1/p' "$team/provenance.md" | head -1)
awk -v l="${low:-0}" 'BEGIN { exit !(l > 0.5) }' ||
  { echo "FAIL: $team/provenance.md: against the autopilot, Wilson lower bound ${low:-missing}, not above 0.5: ship a team that beats it"; exit 1; }
if awk -v w="$winrate" -v r="$recorded" -v t="$tolerance" 'BEGIN { d = w - r; exit !(d <= t && -d <= t) }'; then
  echo "ok    races as shipped: winrate $winrate against the autopilot over $races races (recorded $recorded)"
else
  echo "FAIL: the shipped team races differently with this build: winrate $winrate against the autopilot over $races" \
       "races, $recorded recorded; retrain with \`${retrain:-f16race train --config configs/default.yaml --run runs/team}\`" \
       "and run scripts/ship_team.sh RUN"
  exit 1
fi
echo "shipped_team: all checks passed"
