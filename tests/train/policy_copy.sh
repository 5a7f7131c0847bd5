#!/usr/bin/env bash
# `export --policy-run` (issue 52): a run with two tail members copied without optimiser state is
# under half its checkpoints' size, flies the same races as the run (replay bytes), holds no
# trainer.pt, and `train --resume` refuses it in one line; a target holding other files and
# --out beside --policy-run are refused in one line each.
# Usage: policy_copy.sh F16RACE_BINARY SMOKE_CONFIG WORK_DIR
set -uo pipefail
bin=$1 config=$2 work=$3
rm -rf "$work" && mkdir -p "$work"
fail() { echo "FAIL: $*"; exit 1; }
run=$work/run copy=$work/copy
"$bin" train --config "$config" --run "$run" --set train.hl_tail_members=2 --set train.hl_tail_share=0.5 --quiet \
  > "$work/train.log" 2>&1 || fail "train: $(tail -n 3 "$work/train.log")"
"$bin" export --run "$run" --policy-run "$copy" > "$work/export.log" 2>&1 || fail "export: $(cat "$work/export.log")"
grep -q "a policy-only copy of $run (2 folders" "$work/export.log" || fail "export said: $(cat "$work/export.log")"
for f in config.yaml checkpoint/LATEST members/1/checkpoint/LATEST export/hl_policy.pt export/ll_policy.pt; do
  [ -f "$copy/$f" ] || fail "the copy has no $f"
done
[ -z "$(find "$copy" -name trainer.pt)" ] || fail "the copy holds a trainer.pt"
[ ! -e "$copy/pool" ] && [ ! -e "$copy/metrics.csv" ] || fail "the copy holds the run's pool or metrics"
size() { find "$1" \( -name ll.pt -o -name hl.pt \) -path "*/checkpoint/*" -printf '%s\n' | awk '{s += $1} END {print s}'; }
full=$(size "$run") small=$(size "$copy")
[ $((2 * small)) -lt "$full" ] || fail "the copy's ll.pt and hl.pt hold $small bytes, the run's $full: not under half"
echo "ok    copy: $small bytes of ll.pt and hl.pt, the run's $full"

# The same races: a replay of each against the autopilot writes the same trajectories.
for r in run copy; do
  "$bin" replay --run "$work/$r" --opponent autopilot --seed 3 --out "$work/replay_$r" > /dev/null 2>&1 ||
    fail "replay of the $r"
done
n=0
for f in "$work"/replay_run/replay_agent*.csv "$work"/replay_run/replay_goals.csv; do
  cmp -s "$f" "$work/replay_copy/$(basename "$f")" || fail "replay: $(basename "$f") differs between the run and its copy"
  n=$((n + 1))
done
[ $n -ge 3 ] || fail "replay wrote $n trajectory files"
echo "ok    the copy flies the run's races ($n replay files identical)"

# One line, exit 2, naming what is wrong.
refused() {  # refused EXPECTED_TEXT COMMAND...
  local want=$1 msg rc
  shift
  msg=$("$@" 2>&1); rc=$?
  [ $rc -eq 2 ] && [ "$(printf '%s\n' "$msg" | wc -l)" -eq 1 ] && [[ "$msg" == *"$want"* ]] || fail "rc $rc: $msg"
}
refused "$copy/checkpoint/$(cat "$copy/checkpoint/LATEST"): a policy-only copy" "$bin" train --resume "$copy" --quiet
refused "holds" "$bin" export --run "$run" --policy-run "$run"
refused "--out with --policy-run" "$bin" export --run "$run" --policy-run "$work/c2" --out "$work/e2"
[ -f "$run/metrics.csv" ] && [ ! -e "$work/c2" ] || fail "a refused export changed the run or wrote its copy"
echo "OK"
