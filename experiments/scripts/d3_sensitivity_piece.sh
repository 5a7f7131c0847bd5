#!/usr/bin/env bash
# One seed of notebook 112 (how sensitive is the Fig. 3 study's ES+D3 result?): six HL-only runs
# on one frozen pilot, each exactly a study cell at 8 s (configs/long.yaml, 3.5 M env steps, the
# ensemble of three tails; the study's own overrides) with one arm's keys on top:
#   d2, d3             the study's es_d2 and es_d3
#   d3_fine            es_d3 with 161 C51 atoms (spacing 0.31 instead of 0.98 on the same support)
#   d3_huber           es_d3 with hl.d3_loss huber_mean (the paper's Eq. 5 read literally)
#   d2_keep, d3_keep   es_d2 and es_d3 with train.keep_hl_decisions true
# two at a time on one thread each (as the study's jobs), then one round robin of the six (512
# races per pairing, common random numbers, long tracks, seed 1), kept by d3_sensitivity.py.
#
#   experiments/scripts/d3_sensitivity_piece.sh PILOT_RUN SEED OUT_DIR KEEP_DIR
#
# OUT_DIR/sSEED holds the runs and the tournament (resumable: rerun the same command after a stop);
# KEEP_DIR/sSEED.json the piece's summary. F16RACE (default build/f16race) chooses the binary.
set -euo pipefail
[ $# -eq 4 ] && [[ "$2" =~ ^[0-9]+$ ]] ||
  { echo "usage: experiments/scripts/d3_sensitivity_piece.sh PILOT_RUN SEED OUT_DIR KEEP_DIR" >&2; exit 2; }
here="$(cd "$(dirname "$0")/../.." && pwd)"
bin="$(realpath "${F16RACE:-$here/build/f16race}")"
[ -f "$1/checkpoint/LATEST" ] || { echo "$1: not a trained run (no checkpoint/LATEST)" >&2; exit 2; }
pilot="$(realpath --relative-to="$here" "$1")" seed="$2"
mkdir -p "$3/s$seed" "$4"
out="$(cd "$3/s$seed" && pwd)" keep="$(cd "$4" && pwd)"
cd "$here"

arm_keys() {
  case "$1" in
    d2) echo "hl.agent=es_d2" ;;
    d3) echo "hl.agent=es_d3" ;;
    d3_fine) echo "hl.agent=es_d3 hl.n_atoms=161" ;;
    d3_huber) echo "hl.agent=es_d3 hl.d3_loss=huber_mean" ;;
    d2_keep) echo "hl.agent=es_d2 train.keep_hl_decisions=true" ;;
    d3_keep) echo "hl.agent=es_d3 train.keep_hl_decisions=true" ;;
  esac
}

# train_arm ARM: the arm's run, resumed from its checkpoint when it has one.
train_arm() {
  local run="$out/$1" args=() k
  if [ -f "$run/checkpoint/LATEST" ]; then
    "$bin" --threads 1 train --resume "$run" --quiet
    return
  fi
  for k in "train.ll_from=$pilot" $(arm_keys "$1") "seed=$seed" "race.dt_hl_s=8" "train.total_env_steps=3500000"; do
    args+=(--set "$k")
  done
  "$bin" --threads 1 train --config configs/long.yaml "${args[@]}" --run "$run" --quiet --overwrite
}

for pair in "d2 d3" "d2_keep d3_keep" "d3_fine d3_huber"; do
  set -- $pair
  train_arm "$1" > "$out/$1.log" 2>&1 & first=$!
  train_arm "$2" > "$out/$2.log" 2>&1 || { wait "$first" || true; echo "$2 failed: $out/$2.log" >&2; exit 1; }
  wait "$first" || { echo "$1 failed: $out/$1.log" >&2; exit 1; }
done
if [ ! -f "$out/tour/done.txt" ]; then
  "$bin" --threads 2 tournament --runs "$out"/{d2,d3,d3_fine,d3_huber,d2_keep,d3_keep} --no-untrained \
    --races 512 --seed 1 --tracks configs/long.yaml --out "$out/tour"
fi
F16RACE="$bin" python3 experiments/scripts/d3_sensitivity.py --keep-piece "$out" "$keep"
