#!/usr/bin/env bash
# Data-parallel training over a group of ranks (issue 18), on loopback:
#  - two ranks train one run: rank 0 writes it, the checkpoint holds both ranks' states;
#  - (b) resume: a group stopped after 9 updates and resumed with --resume ends with the same
#    ll.pt, hl.pt and metrics (but wall time) as the unbroken group run;
#  - a checkpoint of 2 ranks is refused by one process (and the reverse), naming the fix;
#  - race.n_env that does not split over the ranks, and ranks with different configs, are refused;
#  - a rank killed or hung mid-run: the other stops within the timeout with one line naming it,
#    non-zero exit, the last checkpoint intact, and the group resumes from it;
#  - Ctrl-C of the launcher: exit 130 with a checkpoint at the last update, no failure reported;
#  - bench train --nproc 2 reports each rank's throughput and time in collectives.
# (a), a step over ranks against one process's on the union of the samples: tests/agents/test_replicas.cpp
# (threads as ranks) and replicas_over_gloo.sh (ctest dist_replicas_over_gloo).
# Usage: dist_train.sh F16RACE_BINARY SMOKE_CONFIG WORK_DIR
set -euo pipefail
bin=$1 config=$2 work=$3
rm -rf "$work" && mkdir -p "$work"
fail() { echo "FAIL: $*"; exit 1; }
source "$(dirname "$0")/rank_faults.sh"
steps=(--set train.total_env_steps=1600)
# Metrics without the wall-time columns (wall_s, samples_per_s).
metrics() { cut -d, -f1-3,6- "$1/metrics.csv"; }
latest() { echo "$1/checkpoint/$(cat "$1/checkpoint/LATEST")"; }

"$bin" --threads 1 launch --nproc 2 -- train --config "$config" "${steps[@]}" --run "$work/full" --quiet \
  > "$work/full.log" 2>&1 || fail "2-rank run: $(tail -n 3 "$work/full.log")"
ck=$(latest "$work/full")
[ -f "$ck/trainer.pt" ] && [ -f "$ck/trainer_rank1.pt" ] || fail "the checkpoint lacks a rank's state: $(ls "$ck")"
grep -q "world_size: 2" "$ck/meta.yaml" || fail "meta.yaml does not record the group: $(cat "$ck/meta.yaml")"
rows=$(($(wc -l < "$work/full/metrics.csv") - 1))
[ "$rows" -ge 15 ] || fail "only $rows metrics rows"
grep -q "env_steps: 16[0-9][0-9]" "$ck/meta.yaml" || fail "the group's step count: $(cat "$ck/meta.yaml")"

# (b) Stopped after 9 updates, resumed by the group: the same run.
"$bin" --threads 1 launch --nproc 2 -- train --config "$config" "${steps[@]}" --run "$work/split" --max-updates 9 \
  --quiet > "$work/split1.log" 2>&1 || fail "first half: $(tail -n 3 "$work/split1.log")"
cp -r "$work/split" "$work/split_at9"
"$bin" --threads 1 launch --nproc 2 -- train --resume "$work/split" --quiet > "$work/split2.log" 2>&1 ||
  fail "resume: $(tail -n 3 "$work/split2.log")"
for f in ll.pt hl.pt; do
  cmp "$(latest "$work/full")/$f" "$(latest "$work/split")/$f" || fail "resumed group: $f differs from the unbroken run's"
done
cmp <(metrics "$work/full") <(metrics "$work/split") || fail "resumed group: metrics differ from the unbroken run's"
echo "resume: the group's run stopped at update 9 and resumed ends with the unbroken run's bytes"

# A checkpoint written by 2 ranks is refused by one process, and the reverse.
set +e
msg=$("$bin" --threads 1 train --resume "$work/split_at9" 2>&1)
rc=$?
set -e
[ $rc -eq 2 ] && [[ "$msg" == *"written by a group of 2 ranks"*"launch --nproc 2"* ]] || fail "1 process resuming 2 ranks' checkpoint: rc $rc: $msg"
"$bin" --threads 1 train --config "$config" --run "$work/single" --max-updates 2 --quiet > /dev/null
set +e
msg=$("$bin" --threads 1 launch --nproc 2 -- train --resume "$work/single" 2>&1)
rc=$?
set -e
[ $rc -eq 2 ] && [[ "$msg" == *"written by one process; resume it with one process"* ]] || fail "2 ranks resuming 1 process's checkpoint: rc $rc: $msg"

# race.n_env = 4 over 3 ranks.
set +e
msg=$("$bin" --threads 1 launch --nproc 3 -- train --config "$config" --run "$work/three" --quiet 2>&1)
rc=$?
set -e
[ $rc -eq 2 ] && [[ "$msg" == *"race.n_env = 4 does not split evenly over 3 ranks"* ]] || fail "n_env over 3 ranks: rc $rc: $msg"
[ ! -e "$work/three/checkpoint/LATEST" ] || fail "a refused group trained"

# Ranks with different configs are refused by both, before training.
mm0=(train --config "$config" --run "$work/mm" --quiet)
mm1=(train --config "$config" --run "$work/mm" --set ll.n_epochs=3 --quiet)
refused_pair "$work/mm" mm0 mm1
[ ! -e "$work/mm/metrics.csv" ] || fail "mismatched ranks trained"

# A rank killed (KILL) or hung (STOP) mid-run: the other stops with one line naming it, the last
# checkpoint stays; the group resumes from the killed run's.
for sig in KILL STOP; do
  lose_rank1 $sig "$work/lost_$sig/checkpoint/LATEST" "$work/lost_$sig.log" -- \
    "$bin" --threads 1 launch --nproc 2 --timeout 5 -- train --config "$config" --set train.total_env_steps=10000000 \
    --run "$work/lost_$sig" --quiet
  echo "$sig: the group (rank 0, then the launcher ending a stopped rank) ended $took s after rank 1 was lost"
done
mv "$work/lost_KILL" "$work/killed"
ck=$(latest "$work/killed")
for f in ll.pt hl.pt trainer.pt trainer_rank1.pt meta.yaml; do [ -s "$ck/$f" ] || fail "the last checkpoint lost $f"; done
before=$(sed -n 's/^updates: //p' "$ck/meta.yaml")
"$bin" --threads 1 launch --nproc 2 -- train --resume "$work/killed" --max-updates 3 --quiet > "$work/resumed.log" 2>&1 ||
  fail "resume after the kill: $(tail -n 3 "$work/resumed.log")"
after=$(sed -n 's/^updates: //p' "$(latest "$work/killed")/meta.yaml")
[ "$after" -eq $((before + 3)) ] || fail "resumed from update $before, now at $after (expected $((before + 3)))"
echo "killed: the group resumed at update $before"

# Ctrl-C of the launcher: every rank stops after the same update, rank 0 writes its checkpoint.
"$bin" --threads 1 launch --nproc 2 -- train --config "$config" --set train.total_env_steps=10000000 \
  --run "$work/int" --quiet > "$work/int.log" 2>&1 &
launcher=$!
for _ in $(seq 300); do sleep 0.1; [ -f "$work/int/checkpoint/LATEST" ] && break; done
sleep 1
kill -INT $launcher
set +e
wait $launcher
rc=$?
set -e
[ $rc -eq 130 ] || fail "Ctrl-C: exit $rc, expected 130: $(tail -n 3 "$work/int.log")"
at=$(sed -n 's/^interrupted: checkpoint written at update \([0-9]*\);.*/\1/p' "$work/int.log")
[ -n "$at" ] && grep -qx "updates: $at" "$(latest "$work/int")/meta.yaml" || fail "Ctrl-C: no checkpoint at the last update: $(cat "$work/int.log")"
! grep -q "exited with status" "$work/int.log" || fail "Ctrl-C reported as a failure: $(cat "$work/int.log")"

# bench train over 2 ranks.
out=$("$bin" --threads 1 bench train --nproc 2 --config "$config" --updates 3 2>&1) || fail "bench train --nproc 2: $out"
[[ "$out" == *"over 2 ranks"* && "$out" == *"rank 1: 2 envs"*"in collectives"* ]] || fail "bench train --nproc 2 printed: $out"
echo "OK"
