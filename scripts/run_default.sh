#!/usr/bin/env bash
# The main job on the default configuration: set up, build, fly a scripted manoeuvre on both
# aero models and benchmark the batched simulator. Outputs go to runs/default/.
set -euo pipefail
cd "$(dirname "$0")/.."
scripts/setup.sh
scripts/build.sh --target f16race
out=runs/default
mkdir -p "$out"
for model in morelli stevens; do
  build/f16race simulate --model "$model" --trim-vt 540 --trim-alt 5000 \
    --commands configs/manoeuvre_commands.csv --duration 20 --sample 0.02 \
    --out "$out/manoeuvre_$model.csv"
done
build/f16race bench sim | tee "$out/bench_sim.txt"
