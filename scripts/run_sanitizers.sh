#!/usr/bin/env bash
# Builds everything with AddressSanitizer and UndefinedBehaviorSanitizer in build-sanitize/ and
# runs the whole test suite there. Not part of CI: minutes to tens of minutes on 2 cores from an empty folder,
# on top of CI's own build and tests (docs/robustness.md: the run time and the result).
# Usage: scripts/run_sanitizers.sh [--quick] [ctest arguments, e.g. -R RaceEnv]
#   --quick: only the torch-free half (simulator, AeroBench files, race env, I/O and their tests),
#            a few minutes.
set -euo pipefail
cd "$(dirname "$0")/.."
scripts/setup.sh
flags="-fsanitize=address,undefined -fno-omit-frame-pointer -fno-sanitize-recover=undefined"
cmake -S . -B build-sanitize -DCMAKE_BUILD_TYPE=RelWithDebInfo \
  -DCMAKE_CXX_FLAGS="$flags" -DCMAKE_EXE_LINKER_FLAGS="-fsanitize=address,undefined" >/dev/null
quick=0
if [ "${1:-}" = "--quick" ]; then
  shift
  quick=1
fi
# LibTorch and OpenMP keep thread pools and caches alive to the end: leak reports would be theirs.
# UBSan stops at the first finding (-fno-sanitize-recover), so a finding fails the test.
export ASAN_OPTIONS="detect_leaks=0:abort_on_error=1" UBSAN_OPTIONS="print_stacktrace=1:halt_on_error=1"
export OPENBLAS_NUM_THREADS=1
start=$(date +%s)
if [ "$quick" = 1 ]; then
  cmake --build build-sanitize -j "$(nproc)" --target dynamics_tests aerobench_files_tests race_tests io_tests
  for t in dynamics_tests aerobench_files_tests race_tests io_tests; do build-sanitize/tests/$t --gtest_brief=1 "$@"; done
else
  cmake --build build-sanitize -j "$(nproc)"
  (cd build-sanitize && ctest --output-on-failure -j "$(nproc)" "$@")
fi
echo "sanitizer build and tests passed in $(( $(date +%s) - start )) s (build-sanitize/)"
