#!/usr/bin/env bash
# Configures (Release, this machine's SIMD) and builds f16race into build/. Extra arguments are
# passed to `cmake --build` (e.g. `--target f16race`).
set -euo pipefail
cd "$(dirname "$0")/.."
cmake -S . -B build -DCMAKE_BUILD_TYPE=Release ${F16RACE_CMAKE_ARGS:-} >/dev/null
cmake --build build -j "$(nproc)" "$@"
