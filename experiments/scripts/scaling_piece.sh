#!/usr/bin/env bash
# One piece of notebook 68's budget MULT: es_d2 and es_d3 of seed S at 8 s on one frozen pilot,
# trained as experiments/configs/study_scaling.yaml at MULT x 1.75 M HL-only env steps, each run against its
# own controls, then both runs' controls added to KEEP_FILE (scaling_verdict.py --keep-pieces;
# commit it). A budget too long for one machine (x16: ~45 min per piece on two cores) is trained
# seed by seed, so a lost machine costs at most the piece under way.
#
#   experiments/scripts/scaling_piece.sh PILOT_RUN MULT SEED OUT_DIR KEEP_FILE
#
# OUT_DIR/xMULT_sS is the piece's study folder (resumable: rerun the same command after a stop).
# F16RACE (default build/f16race) and F16RACE_THREADS (default 2) choose the binary and threads.
set -euo pipefail
[ $# -eq 5 ] && [[ "$2" =~ ^[0-9]+$ ]] && [[ "$3" =~ ^[0-9]+$ ]] ||
  { echo "usage: experiments/scripts/scaling_piece.sh PILOT_RUN MULT SEED OUT_DIR KEEP_FILE" >&2; exit 2; }
here="$(cd "$(dirname "$0")/../.." && pwd)"
pilot="$1" mult="$2" seed="$3"
source "$here/experiments/scripts/pilot_study_steps.sh"
pilot_study_binary "$pilot"
mkdir -p "$4"
root="$(cd "$4" && pwd)"
out="$root/x${mult}_s$seed" config="$root/x${mult}_s$seed.yaml"
pilot_study_config "$here/experiments/configs/study_scaling.yaml" "$config" \
  "/^set:/s#PILOT_RUN#$(realpath --relative-to="$here" "$pilot")#; s#^total_env_steps: .*#total_env_steps: $((1750000 * mult))#;
   s#^seeds: .*#seeds: [$seed]#" piece
cd "$here"
"$bin" --threads "$threads" study --config "$config" --out "$out"
pilot_study_controls "$bin" "$threads" "$out"/dt8/es_d{2,3}_s"$seed"
F16RACE="$bin" python3 experiments/scripts/scaling_verdict.py --keep-pieces "$out" "$5"
