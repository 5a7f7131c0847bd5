#!/usr/bin/env bash
# experiments/scripts/scaling_piece.sh writes the whole budget's config with one seed and MULT x 1.75 M steps,
# refuses a missing pilot, and keeps nothing when no run has its controls (the binary here is
# /bin/true, so nothing is trained). Usage: scaling_piece_config.sh SOURCE_DIR WORK_DIR
set -uo pipefail
src=$1 work=$2
rm -rf "$work" && mkdir -p "$work"
fail() { echo "FAIL: $*"; exit 1; }
out=$("$src/experiments/scripts/scaling_piece.sh" "$work/nowhere" 16 2 "$work/out" "$work/x16.json" 2>&1) && fail "a missing pilot accepted"
[[ "$out" == *"nowhere: not a trained run"* ]] || fail "missing pilot message: $out"
out=$(F16RACE=/bin/true "$src/experiments/scripts/scaling_piece.sh" "$src/examples/trained_team" 16 2 "$work/out" "$work/x16.json" 2>&1) &&
  fail "a piece without controls kept"
[[ "$out" == *"nothing to keep"* ]] || fail "no controls message: $out"
[ ! -e "$work/x16.json" ] || fail "a keep file written without controls"
cfg="$work/out/x16_s2.yaml"
grep -qx "seeds: \[2\]" "$cfg" && grep -qx "total_env_steps: 28000000" "$cfg" &&
  grep -q "train.ll_from=examples/trained_team" "$cfg" || fail "config: $(cat "$cfg")"
diff <(grep -vE "^(seeds|total_env_steps|set):" "$cfg") <(grep -vE "^(seeds|total_env_steps|set):" "$src/experiments/configs/study_scaling.yaml") ||
  fail "the piece's config differs from the budget's beyond seed, steps and pilot"
echo "scaling_piece: one seed at MULT x 1.75 M, pilot checked, nothing kept without controls"
