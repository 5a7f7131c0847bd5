#!/usr/bin/env bash
# Builds everything with AddressSanitizer and UndefinedBehaviorSanitizer in build-sanitize/ and
# runs the unit tests there. Not part of CI (the instrumented build and tests take longer than
# the CI budget allows on 2 cores); README "Sanitizers" gives the run time and the result.
# Usage: scripts/run_sanitizers.sh [ctest arguments, e.g. -R RaceEnv]
set -euo pipefail
cd "$(dirname "$0")/.."
scripts/setup.sh
flags="-fsanitize=address,undefined -fno-omit-frame-pointer -fno-sanitize-recover=undefined"
cmake -S . -B build-sanitize -DCMAKE_BUILD_TYPE=RelWithDebInfo \
  -DCMAKE_CXX_FLAGS="$flags" -DCMAKE_EXE_LINKER_FLAGS="-fsanitize=address,undefined" >/dev/null
cmake --build build-sanitize -j "$(nproc)"
cd build-sanitize
# LibTorch and OpenMP keep thread pools and caches alive to the end: leak reports would be theirs.
# UBSan aborts on the first finding (-fno-sanitize-recover), so a finding fails the test.
export ASAN_OPTIONS="detect_leaks=0:abort_on_error=1" UBSAN_OPTIONS="print_stacktrace=1:halt_on_error=1"
export OPENBLAS_NUM_THREADS=1
start=$(date +%s)
ctest --output-on-failure -j "$(nproc)" "$@"
echo "sanitizer tests passed in $(( $(date +%s) - start )) s (build-sanitize/)"
