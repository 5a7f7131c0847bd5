#!/usr/bin/env bash
# One block of the Fig. 3 study (notebook 72): seed S's four variants at both HL intervals on one
# frozen pilot, their round robin, each run against its own controls, then the block's summary
# kept in the repository (commit it): a machine's run folders do not outlive it.
#
#   experiments/scripts/study_block.sh PILOT_RUN OUT_DIR KEEP_DIR SEED
#
# OUT_DIR/sS is the block's study folder (resumable: rerun the same command after a stop), and
# OUT_DIR/sS.yaml the config it was trained with (experiments/configs/study_pilot.yaml with the pilot, as a
# path from the repository's root, and the seed filled in);
# KEEP_DIR/sS.json its summary, which `experiments/scripts/study_verdicts.py KEEP_DIR` reads. F16RACE (default
# build/f16race) and F16RACE_THREADS (default 2) choose the binary and threads.
set -euo pipefail
[ $# -eq 4 ] && [[ "$4" =~ ^[0-9]+$ ]] ||
  { echo "usage: experiments/scripts/study_block.sh PILOT_RUN OUT_DIR KEEP_DIR SEED" >&2; exit 2; }
here="$(cd "$(dirname "$0")/../.." && pwd)"
pilot="$1" seed="$4"
source "$here/experiments/scripts/pilot_study_steps.sh"
pilot_study_binary "$pilot"
mkdir -p "$2" "$3"
root="$(cd "$2" && pwd)" keep="$(cd "$3" && pwd)"
out="$root/s$seed" config="$root/s$seed.yaml"  # the config beside the study folder, which `study` owns
pilot_study_config "$here/experiments/configs/study_pilot.yaml" "$config" \
  "s#PILOT_RUN#$(realpath --relative-to="$here" "$pilot")#; s#BLOCK_SEED#$seed#" block
cd "$here"
"$bin" --threads "$threads" study --config "$config" --out "$out"
pilot_study_controls "$bin" "$threads" "$out"/dt{8,20}/es{,_d1,_d2,_d3}_s"$seed"
F16RACE="$bin" python3 experiments/scripts/study_verdicts.py --keep-block "$out" "$keep"
