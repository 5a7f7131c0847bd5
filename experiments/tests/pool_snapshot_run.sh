#!/usr/bin/env bash
# experiments/scripts/pool_snapshot_run.sh (notebook 81): a pool snapshot made a policy-only run folder holds
# the snapshot's networks byte for byte with the run's config and config hash, and replay flies it;
# a missing snapshot, an existing target and a bad step name are refused in one line each, and
# nothing is written for them.
# Usage: pool_snapshot_run.sh F16RACE_BINARY SCRIPT SMOKE_CONFIG WORK_DIR
set -uo pipefail
bin=$1 script=$2 config=$3 work=$4
rm -rf "$work" && mkdir -p "$work"
fail() { echo "FAIL: $*"; exit 1; }
run=$work/run
"$bin" train --config "$config" --run "$run" --quiet > "$work/train.log" 2>&1 || fail "train: $(tail -n 3 "$work/train.log")"
step=$(ls "$run/pool" | tail -n 1)
[ -n "$step" ] || fail "the smoke run kept no pool snapshot"
snap=$work/$step
"$script" "$run" "$step" "$snap" || fail "the script failed on $run/pool/$step"
ck="$snap/checkpoint/$(cat "$snap/checkpoint/LATEST")"
for f in hl.pt ll.pt; do cmp -s "$run/pool/$step/$f" "$ck/$f" || fail "$f is not the snapshot's"; done
cmp -s "$run/config.yaml" "$snap/config.yaml" || fail "config.yaml is not the run's"
want=$(awk '/^config_hash:/ {print $2}' "$run/checkpoint/$(cat "$run/checkpoint/LATEST")/meta.yaml")
grep -qx "config_hash: $want" "$ck/meta.yaml" || fail "meta.yaml: $(cat "$ck/meta.yaml")"
grep -qx "env_steps: $((10#${step#step_}))" "$ck/meta.yaml" || fail "meta.yaml: $(cat "$ck/meta.yaml")"
grep -qx "policy_only: true" "$ck/meta.yaml" || fail "meta.yaml: $(cat "$ck/meta.yaml")"
"$bin" replay --run "$snap@center" --opponent autopilot --seed 2 --out "$work/replay" > "$work/replay.log" 2>&1 ||
  fail "replay of the snapshot: $(tail -n 2 "$work/replay.log")"
ls "$work"/replay/replay_agent*.csv > /dev/null 2>&1 || fail "replay wrote no trajectories"
echo "ok    $step flies as a run folder"

refused() {  # refused EXPECTED_TEXT ARGS...
  local want=$1 msg rc
  shift
  msg=$("$script" "$@" 2>&1); rc=$?
  [ $rc -eq 2 ] && [ "$(printf '%s\n' "$msg" | wc -l)" -eq 1 ] && [[ "$msg" == *"$want"* ]] || fail "rc $rc: $msg"
}
refused "no snapshot there" "$run" step_0000000001 "$work/a"
refused "exists; give a new folder" "$run" "$step" "$snap"
mkdir -p "$run/pool/stepX" && cp "$run/pool/$step"/*.pt "$run/pool/stepX/"
refused "expected step_<env steps>" "$run" stepX "$work/b"
refused "usage" "$run" "$step"
[ ! -e "$work/a" ] && [ ! -e "$work/b" ] && [ -z "$(ls -d "$work"/*.tmp 2>/dev/null)" ] || fail "a refused call wrote a folder"
echo "OK"
