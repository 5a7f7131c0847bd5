#!/usr/bin/env bash
# `f16race export` end to end: train a tiny run, export it, load the modules with plain PyTorch
# (Debian's python3-torch) and compare with the in-process outputs, also for an ensemble high level;
# refuse a missing run.
# Usage: export_python.sh F16RACE_BINARY SMOKE_CONFIG WORK_DIR
set -euo pipefail
bin=$1 config=$2 work=$3
here=$(cd "$(dirname "$0")" && pwd)
rm -rf "$work" && mkdir -p "$work"
"$bin" train --config "$config" --run "$work/run" --max-updates 2 --quiet
"$bin" export --run "$work/run" --out "$work/export"
/usr/bin/python3 "$here/check_export.py" "$work/export"
# An ensemble high level (train.hl_tail_members: the run and its forked tails, trained to their
# budget), exported as one module with a submodule per member.
"$bin" train --config "$config" --run "$work/ens" --set train.hl_tail_members=2 --set train.hl_tail_share=0.5 --quiet
"$bin" export --run "$work/ens" --out "$work/ens_export"
grep -q "ensemble of 2 critics" "$work/ens_export/README.md" || { echo "FAIL: the export is not a 2-member ensemble"; exit 1; }
/usr/bin/python3 "$here/check_export.py" "$work/ens_export"
set +e
msg=$("$bin" export --run "$work/no_such_run" --out "$work/x" 2>&1)
rc=$?
set -e
if [ "$rc" -ne 2 ] || [[ "$msg" != *"no_such_run: not a training run"* ]] || [ -e "$work/x" ]; then
  echo "FAIL: missing run not refused cleanly (rc $rc): $msg"
  exit 1
fi
echo "OK"
