#!/usr/bin/env bash
# The run folder from the command line (issue 15): a second writer is refused while the first
# trains, SIGINT ends a run with status 130 after its checkpoint, a fresh run refuses a folder
# without LATEST, --overwrite moves the old run aside intact, and --max-updates stops early with status 0.
# Usage: run_folder_cli.sh F16RACE_BINARY CONFIG WORK_DIR
set -uo pipefail
bin=$1 config=$2 work=$3
rm -rf "$work" && mkdir -p "$work"
fail() { echo "FAIL: $*"; exit 1; }
run="$work/r"
"$bin" train --config "$config" --run "$run" --set train.total_env_steps=400000 --quiet &
pid=$!
for _ in $(seq 1 600); do [ -f "$run/checkpoint/LATEST" ] && break; sleep 0.02; done
[ -f "$run/checkpoint/LATEST" ] || fail "no checkpoint appeared"
msg=$("$bin" train --resume "$run" --quiet 2>&1); rc=$?
[ "$rc" -eq 2 ] && [[ "$msg" == *"is in use by another f16race train (pid $pid)"* ]] || fail "second writer: rc $rc: $msg"
kill -INT "$pid"
wait "$pid"; rc=$?
[ "$rc" -eq 130 ] || fail "SIGINT: exit status $rc, expected 130"
latest=$(cat "$run/checkpoint/LATEST")
[ -f "$run/checkpoint/$latest/trainer.pt" ] || fail "no checkpoint after SIGINT"
rm "$run/checkpoint/LATEST"
msg=$("$bin" train --config "$config" --run "$run" --seed 4 --quiet 2>&1); rc=$?
[ "$rc" -eq 2 ] && [[ "$msg" == *"already holds a run"* ]] || fail "fresh run over a run without LATEST: rc $rc: $msg"
[ -f "$run/checkpoint/$latest/trainer.pt" ] || fail "the refused run changed the folder"
# Refused, a start over a run (or a resume in another numeric mode) leaves it byte for byte, its lock included.
echo "$latest" > "$run/checkpoint/LATEST"
sig() { (cd "$1" && find . -type f | LC_ALL=C sort | xargs md5sum) | md5sum; }
before=$(sig "$run")
msg=$("$bin" train --config "$config" --run "$run" --quiet 2>&1); rc=$?
[ "$rc" -eq 2 ] && [[ "$msg" == *"already holds a run"* ]] || fail "fresh run over a run: rc $rc: $msg"
[ "$(sig "$run")" = "$before" ] || fail "the refused start changed the run's files (its .lock?)"
meta="$run/checkpoint/$latest/meta.yaml"
cp "$meta" "$work/meta.keep"
sed -i 's/^numerics: .*/numerics: turbo/' "$meta"
before=$(sig "$run")
msg=$("$bin" train --resume "$run" --quiet 2>&1); rc=$?
[ "$rc" -eq 2 ] && [[ "$msg" == *"meta.yaml: numerics is 'turbo'"* ]] || fail "resume with a bad numerics record: rc $rc: $msg"
[ "$(sig "$run")" = "$before" ] || fail "the refused resume changed the run's files"
cp "$work/meta.keep" "$meta"
rm "$run/checkpoint/LATEST"
"$bin" train --config "$config" --run "$run" --seed 4 --overwrite --max-updates 1 --quiet || fail "--overwrite"
[ -f "$run.old-1/checkpoint/$latest/trainer.pt" ] || fail "--overwrite did not keep the old run in $run.old-1"
grep -q "^seed: 4" "$run/config.yaml" || fail "--overwrite did not start the new run"
# --max-updates before the budget: a checkpoint and status 0, the tail members left for --resume
# (they once were trained at once and the run failed on the missing members/1 folder).
msg=$("$bin" train --config "$config" --run "$work/m" --set train.hl_tail_members=2 --set train.hl_tail_share=0.5 --max-updates 1 2>&1); rc=$?
[ "$rc" -eq 0 ] && [[ "$msg" == *"stopped by --max-updates at "*"continue with --resume $work/m"* ]] ||
  fail "--max-updates with tail members: rc $rc: $msg"
[ -f "$work/m/checkpoint/LATEST" ] && [ ! -e "$work/m/members" ] || fail "--max-updates: no checkpoint, or members trained"
echo "OK"
