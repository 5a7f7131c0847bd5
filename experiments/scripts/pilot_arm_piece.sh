#!/usr/bin/env bash
# One seed of one arm of notebook 108 (a residual pilot against the paper's): experiments/scripts/seed_arm.sh's
# run, its tournament against the tuned autopilot on its lanes and its own controls (kept as
# KEEP_DIR/sS.json), then a tournament against the autopilot flying the run's racing line
# (`--autopilot-on-line`), whose races.csv and summary.json are kept as KEEP_DIR/sS_online.csv and
# KEEP_DIR/sS_online.json. Resumable: rerun the same command after a stop.
#
#   experiments/scripts/pilot_arm_piece.sh RUNS_DIR KEEP_DIR SEED [--set KEY=VALUE ...]
set -euo pipefail
[ $# -ge 3 ] || { echo "usage: experiments/scripts/pilot_arm_piece.sh RUNS_DIR KEEP_DIR SEED [--set KEY=VALUE ...]" >&2; exit 2; }
here="$(cd "$(dirname "$0")/../.." && pwd)"
"$here/experiments/scripts/seed_arm.sh" "$@"
runs="$(cd "$1" && pwd)" keep="$(cd "$2" && pwd)" seed="$3"
bin="$(realpath "${F16RACE:-$here/build/f16race}")"
if [ ! -f "$runs/l_s$seed/done.txt" ]; then
  "$bin" --threads "${F16RACE_THREADS:-2}" tournament --runs "$runs/s$seed" --no-untrained --with-autopilot \
    --autopilot-on-line --races 512 --out "$runs/l_s$seed"
fi
cp "$runs/l_s$seed/races.csv" "$keep/.s${seed}_online.csv" && mv "$keep/.s${seed}_online.csv" "$keep/s${seed}_online.csv"
cp "$runs/l_s$seed/summary.json" "$keep/.s${seed}_online.json" && mv "$keep/.s${seed}_online.json" "$keep/s${seed}_online.json"
echo "kept $keep/s${seed}_online.{csv,json}"
