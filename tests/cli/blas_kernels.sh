#!/usr/bin/env bash
# Which OpenBLAS kernels LibTorch's GEMMs run on. Reproducible build: Haswell's, whatever the CPU
# and whatever OPENBLAS_CORETYPE the user set (f16race pins it and runs itself again). Native
# build: never the pre-AVX "Prescott" fallback on a CPU with AVX2 or AVX-512 (OpenBLAS 0.3.21 takes
# it for CPUs it does not know; f16race then sets OPENBLAS_CORETYPE), and a user's choice is kept.
# Usage: blas_kernels.sh F16RACE_BINARY
set -uo pipefail
bin=$1
fail() { echo "FAIL: $*"; exit 1; }
core_of() { sed -n 's/.*"blas_core": "\([^"]*\)".*/\1/p' | head -n 1 | tr 'A-Z' 'a-z'; }
mode=$("$bin" --version | sed -n 's/^numerics: \([a-z]*\).*/\1/p')
out=$(env -u OPENBLAS_CORETYPE "$bin" bench nets --samples 16 --repeats 1 --json 2>&1) || fail "bench nets: $out"
grep -q '"blas_core": "' <<< "$out" || fail "bench nets --json names no blas_core: $out"
grep -q "\"numerics\": \"$mode\"" <<< "$out" || fail "bench nets --json does not name the $mode build: $out"
core=$(core_of <<< "$out")
user=$(OPENBLAS_CORETYPE=Prescott "$bin" bench nets --samples 16 --repeats 1 --json 2>&1 | core_of)
if [ "$mode" = reproducible ]; then
  [ "$core" = haswell ] || fail "the reproducible build runs OpenBLAS's '$core' kernels, not Haswell's"
  [ "$user" = haswell ] || fail "OPENBLAS_CORETYPE=Prescott was not pinned to Haswell in the reproducible build: '$user'"
  echo "OK (reproducible: Haswell, pinned)"
  exit 0
fi
if [ -z "$core" ]; then echo "OK (LibTorch's BLAS is not OpenBLAS here)"; exit 0; fi
if grep -qwE 'avx2|avx512f' /proc/cpuinfo && [ "$core" = prescott ]; then
  fail "OpenBLAS kernels $core on a CPU with AVX2/AVX-512"
fi
[ "$user" = prescott ] || fail "the user's OPENBLAS_CORETYPE=Prescott was not kept: $user"
echo "OK (native: $core)"
