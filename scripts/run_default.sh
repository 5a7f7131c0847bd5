#!/usr/bin/env bash
# The main job on the default configuration: set up, build, and train a 4 vs 4 es_d2 agent
# (10-14 minutes on 2 cores with the build: 13 min 39 s on a fresh clone, Intel Xeon, stop 48; training ~5-6 min). Progress is shown live; results go to runs/default_<time>/.
set -euo pipefail
cd "$(dirname "$0")/.."
scripts/setup.sh
scripts/build.sh --target f16race
run="runs/default_$(date +%Y%m%d_%H%M%S)"
build/f16race train --config configs/default.yaml --run "$run" "$@"
echo "metrics: $run/metrics.csv   checkpoint: $run/checkpoint/   resume: build/f16race train --resume $run"
