#!/usr/bin/env bash
# The main job on the default configuration: set up, build, and train a 4 vs 4 es_d2 agent
# (its time: docs/results.md "The main job"). Progress is shown live; results go to runs/default_<time>/.
set -euo pipefail
cd "$(dirname "$0")/.."
scripts/setup.sh
scripts/build.sh --target f16race
run="runs/default_$(date +%Y%m%d_%H%M%S)"
build/f16race train --config configs/default.yaml --run "$run" "$@"
echo "metrics: $run/metrics.csv   checkpoint: $run/checkpoint/   resume: build/f16race train --resume $run"
