#!/usr/bin/env bash
# A tournament killed with SIGKILL part way and run again goes on from its journal: the rerun says
# how many races it kept (as many as the journal held at the kill), its races.csv, pairings.csv
# and summary.json are the bytes of an unbroken tournament, and no journal is left once it is
# written.
# Usage: tournament_resume.sh F16RACE_BINARY SMOKE_CONFIG WORK_DIR
set -uo pipefail
bin=$(realpath "$1") smoke=$(realpath "$2") work=$(realpath -m "$3")
rm -rf "$work" && mkdir -p "$work" && cd "$work" || exit 1
fail() {
  echo "FAIL: $*"
  exit 1
}
journal_races() {  # whole lines after the two of the header
  if [ -e .tour.journal ]; then echo $(($(wc -l < .tour.journal) - 2)); else echo 0; fi
}

"$bin" train --config "$smoke" --run run --max-updates 2 --quiet >/dev/null || fail "setup: train"
T() { "$bin" tournament --runs run --controls --races 64 --batch 8 --bootstrap 100 --out "$1"; }
T ref > ref.log 2>&1 || fail "reference tournament: $(tail -3 ref.log)"
total=$(grep -c . ref/races.csv)
total=$((total - 1))
"$bin" tournament --runs run --controls --races 64 --batch 8 --bootstrap 100 --out tour > first.log 2>&1 &
pid=$!  # the program itself, not a subshell: the kill must reach it
# The kill lands once the journal holds a tenth of the races.
for _ in $(seq 1 1200); do
  [ "$(journal_races)" -ge $((total / 10)) ] && break
  kill -0 $pid 2>/dev/null || break
  sleep 0.05
done
kill -9 $pid 2>/dev/null
wait $pid 2>/dev/null
[ ! -e tour/done.txt ] || fail "the tournament ended before the kill"
at_kill=$(journal_races)
[ "$at_kill" -ge $((total / 10)) ] || fail "the journal held $at_kill races at the kill: $(tail -2 first.log)"
T tour > rerun.log 2>&1 || fail "rerun: $(tail -3 rerun.log)"
kept=$(sed -n 's/^resuming: \([0-9]*\) races kept.*/\1/p' rerun.log)
[ "$kept" = "$at_kill" ] || fail "the rerun kept '${kept}' races of the $at_kill journaled: $(head -2 rerun.log)"
for f in races.csv pairings.csv summary.json summary.md; do
  cmp -s "ref/$f" "tour/$f" || fail "$f differs from the unbroken tournament's"
done
[ ! -e .tour.journal ] || fail "the journal outlived its tournament"
echo "OK: killed after $at_kill of $total races; the rerun kept them, raced the rest, and wrote the unbroken tournament's bytes"
