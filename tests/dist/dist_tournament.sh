#!/usr/bin/env bash
# A tournament over a group of ranks (issue 18), on loopback:
#  (c) `launch --nproc 2` and `--nproc 3` write the same races.csv and summary.json as one process;
#  a rank started with other options is refused by every rank, before any race;
#  a rank killed mid-tournament: the other stops within the timeout, one line naming the lost
#  rank, non-zero exit, no report written; a hung (stopped) rank likewise;
#  a bad RANK is refused with one line.
# Usage: dist_tournament.sh F16RACE_BINARY SMOKE_CONFIG WORK_DIR
set -euo pipefail
bin=$1 config=$2 work=$3
rm -rf "$work" && mkdir -p "$work"
fail() { echo "FAIL: $*"; exit 1; }
source "$(dirname "$0")/rank_faults.sh"
"$bin" --threads 1 train --config "$config" --run "$work/a" --max-updates 2 --quiet
"$bin" --threads 1 train --config "$config" --run "$work/b" --max-updates 2 --seed 2 --quiet
common=(tournament --runs "$work/a" "$work/b" --controls --with-autopilot --races 6 --batch 20)

"$bin" --threads 1 "${common[@]}" --out "$work/one" > "$work/one.log"
for n in 2 3; do
  "$bin" --threads 1 launch --nproc $n -- "${common[@]}" --out "$work/ranks$n" > "$work/ranks$n.log" 2>&1 ||
    fail "launch --nproc $n: $(tail -n 3 "$work/ranks$n.log")"
  cmp "$work/one/races.csv" "$work/ranks$n/races.csv" || fail "$n ranks: races.csv differs from one process"
  cmp "$work/one/summary.json" "$work/ranks$n/summary.json" || fail "$n ranks: summary.json differs"
done
[ "$(wc -l < "$work/one/races.csv")" -gt 100 ] || fail "too few races to compare"

# Mismatched options: both ranks refuse (exit 2) and name the difference.
mm0=(tournament --runs "$work/a" "$work/b" --races 8 --batch 20 --out "$work/mm")
mm1=("${common[@]}" --out "$work/mm")
refused_pair "$work/mm" mm0 mm1
[ ! -e "$work/mm/races.csv" ] || fail "mismatched ranks raced"

# A lost rank: killed (KILL) or hung (STOP), once the races run.
long=(tournament --runs "$work/a" "$work/b" --races 20000 --batch 64)
for sig in KILL STOP; do
  # the group has formed once rank 0 has made the output folder
  lose_rank1 $sig "$work/lost_$sig" "$work/lost_$sig.log" -- \
    "$bin" --threads 1 launch --nproc 2 --timeout 5 -- "${long[@]}" --out "$work/lost_$sig"
  [ ! -e "$work/lost_$sig/races.csv" ] || fail "$sig: a report was written from a partial tournament"
  echo "$sig: the group ended $took s after rank 1 was lost: $(grep "rank 0 of 2" "$work/lost_$sig.log" | cut -c1-120)"
done

set +e
msg=$(WORLD_SIZE=2 RANK=5 "$bin" "${common[@]}" --out "$work/bad" 2>&1)
rc=$?
set -e
[ $rc -eq 2 ] && [[ "$msg" == *"RANK (--dist-rank) must be in [0, WORLD_SIZE - 1]"* ]] || fail "bad RANK: rc $rc: $msg"
echo "OK"
