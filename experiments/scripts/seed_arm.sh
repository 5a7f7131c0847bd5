#!/usr/bin/env bash
# One seed of one arm of a pilot A/B (notebooks 64, 67, 69-71): train the default config with the
# arm's overrides, race it against the tuned autopilot and its own controls, then keep the seed's
# summary in the repository, since a machine's run folders do not outlive it.
#
#   experiments/scripts/seed_arm.sh RUNS_DIR KEEP_DIR SEED [--set KEY=VALUE ...]
#
# RUNS_DIR/sS is the run and RUNS_DIR/t_sS its tournament (both resumable: rerun the same command
# after a stop); KEEP_DIR/sS.json the summary `experiments/scripts/pilot_seeds_table.py` reads (commit it).
# F16RACE (default build/f16race) and F16RACE_THREADS (default 2) choose the binary and threads;
# the bytes do not depend on the thread count.
set -euo pipefail
[ $# -ge 3 ] || { echo "usage: experiments/scripts/seed_arm.sh RUNS_DIR KEEP_DIR SEED [--set KEY=VALUE ...]" >&2; exit 2; }
here="$(cd "$(dirname "$0")/../.." && pwd)"
mkdir -p "$1" "$2"
runs="$(cd "$1" && pwd)" keep="$(cd "$2" && pwd)" seed="$3"  # absolute: the script changes folder
shift 3
bin="$(realpath "${F16RACE:-$here/build/f16race}")"
threads="${F16RACE_THREADS:-2}"
cd "$runs"
if [ -f "s$seed/checkpoint/LATEST" ]; then
  "$bin" --threads "$threads" train --resume "s$seed" --quiet
else  # a folder without a checkpoint was stopped before its first one: start it afresh
  [ -d "s$seed" ] && set -- "$@" --overwrite
  "$bin" --threads "$threads" train --config "$here/configs/default.yaml" --seed "$seed" --run "s$seed" --quiet "$@"
fi
if [ ! -f "t_s$seed/done.txt" ]; then
  "$bin" --threads "$threads" tournament --runs "s$seed" --no-untrained --with-autopilot --controls \
    --races 512 --out "t_s$seed"
fi
# The summary, with the low level's steady offset from its lane (notebook 74's mechanism), is
# written aside and moved in whole: a stop between the two steps leaves no kept file without it
# (the queue skips seeds whose file exists).
pending="$keep/.pending"
F16RACE="$bin" python3 "$here/experiments/scripts/pilot_seeds_table.py" --keep "$runs" "$seed" "$pending"
F16RACE="$bin" python3 "$here/experiments/scripts/lane_offset.py" --add "$pending/s$seed.json" "s$seed"
mv "$pending/s$seed.json" "$keep/s$seed.json"
echo "kept $keep/s$seed.json"
