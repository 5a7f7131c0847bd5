#!/usr/bin/env bash
# A training run killed with SIGKILL and resumed must end exactly like one that never stopped:
# every learning column of metrics.csv (losses to the last digit, returns, rates) must match.
# Usage: kill_resume.sh F16RACE_BINARY CONFIG WORK_DIR
set -euo pipefail
bin=$1 config=$2 work=$3
rm -rf "$work" && mkdir -p "$work"
"$bin" train --config "$config" --run "$work/whole" --set train.total_env_steps=4000 --quiet
"$bin" train --config "$config" --run "$work/killed" --set train.total_env_steps=4000 --quiet &
pid=$!
# Kill as soon as a checkpoint past the first one exists (checkpoints every 2 updates).
for _ in $(seq 1 600); do
  if [ -f "$work/killed/checkpoint/LATEST" ] && ! grep -q "_u2$" "$work/killed/checkpoint/LATEST"; then break; fi
  sleep 0.01
done
kill -9 "$pid" 2>/dev/null || true
wait "$pid" 2>/dev/null || true
echo "killed at checkpoint $(cat "$work/killed/checkpoint/LATEST")"
"$bin" train --resume "$work/killed" --quiet
# Columns 4 and 5 are wall time and samples/s; everything else must be identical.
if ! diff <(cut -d, -f1-3,6- "$work/whole/metrics.csv") <(cut -d, -f1-3,6- "$work/killed/metrics.csv"); then
  echo "FAIL: the resumed run diverged from the uninterrupted one"
  exit 1
fi
echo "OK: $(($(wc -l < "$work/whole/metrics.csv") - 1)) updates identical after kill -9 and resume"
