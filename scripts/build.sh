#!/usr/bin/env bash
# Configures (Release, this machine's SIMD) and builds f16race into build/. Extra arguments are
# passed to `cmake --build` (e.g. `--target f16race`). A new build/ uses Ninja, which compiles a
# target's sources while the libraries it links are still building (make waits for them); a
# build/ already configured keeps its generator (CMake refuses to switch one).
set -euo pipefail
cd "$(dirname "$0")/.."
generator=()
if [ ! -f build/CMakeCache.txt ] && command -v ninja >/dev/null; then generator=(-G Ninja); fi
cmake -S . -B build "${generator[@]}" -DCMAKE_BUILD_TYPE=Release ${F16RACE_CMAKE_ARGS:-} >/dev/null
cmake --build build -j "$(nproc)" "$@"
