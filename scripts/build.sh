#!/usr/bin/env bash
# Configures (Release) and builds f16race into build/. Extra arguments are passed to
# `cmake --build` (e.g. `--target f16race`). F16RACE_ARCH picks the numeric mode: reproducible
# (the default: the same bytes on every x86-64 CPU with AVX2 and FMA) or native (this CPU's widest
# SIMD; its bytes are its CPU's own). F16RACE_BUILD_DIR builds elsewhere than build/ (both modes
# side by side, say). A new build folder uses Ninja, which compiles a target's sources while the
# libraries it links are still building; one already configured keeps its generator.
set -euo pipefail
cd "$(dirname "$0")/.."
dir=${F16RACE_BUILD_DIR:-build}
generator=()
if [ ! -f "$dir/CMakeCache.txt" ] && command -v ninja >/dev/null; then generator=(-G Ninja); fi
cmake -S . -B "$dir" "${generator[@]}" -DCMAKE_BUILD_TYPE=Release -DF16RACE_ARCH="${F16RACE_ARCH:-reproducible}" \
  ${F16RACE_CMAKE_ARGS:-} >/dev/null
cmake --build "$dir" -j "$(nproc)" "$@"
