#!/usr/bin/env bash
# experiments/scripts/duel_piece.sh writes the scaling budget's config with one seed, MULT x 1.75 M steps and
# 512 races per pairing, refuses a missing pilot, and keeps nothing before the head to head is
# raced (the binary here is /bin/true, so nothing is trained). Usage: duel_piece_config.sh SOURCE_DIR WORK_DIR
set -uo pipefail
src=$1 work=$2
rm -rf "$work" && mkdir -p "$work"
fail() { echo "FAIL: $*"; exit 1; }
out=$("$src/experiments/scripts/duel_piece.sh" "$work/nowhere" 16 4 "$work/out" "$work/keep" 2>&1) && fail "a missing pilot accepted"
[[ "$out" == *"nowhere: not a trained run"* ]] || fail "missing pilot message: $out"
out=$(F16RACE=/bin/true "$src/experiments/scripts/duel_piece.sh" "$src/examples/trained_team" 16 4 "$work/out" "$work/keep" 2>&1) &&
  fail "a piece without its head to head kept"
[[ "$out" == *"round robin has not finished"* ]] || fail "no head to head message: $out"
[ -z "$(ls -A "$work/keep")" ] || fail "a piece kept before it was raced"
cfg="$work/out/x16_s4.yaml"
grep -qx "seeds: \[4\]" "$cfg" && grep -qx "total_env_steps: 28000000" "$cfg" && grep -qx "races_per_pair: 512" "$cfg" &&
  grep -q "train.ll_from=examples/trained_team" "$cfg" || fail "config: $(cat "$cfg")"
diff <(grep -vE "^(seeds|total_env_steps|set|races_per_pair):" "$cfg") \
     <(grep -vE "^(seeds|total_env_steps|set|races_per_pair):" "$src/experiments/configs/study_scaling.yaml") ||
  fail "the piece's config differs from the budget's beyond seed, steps, races and pilot"
echo "duel_piece: one seed at MULT x 1.75 M, 512 races per pairing, pilot checked, nothing kept unraced"
