#!/usr/bin/env bash
# f16race never runs LibTorch's GEMMs on OpenBLAS's pre-AVX "Prescott" fallback on a CPU with
# AVX2 or AVX-512 (OpenBLAS 0.3.21 takes it for CPUs it does not know; f16race then sets
# OPENBLAS_CORETYPE and runs itself again), and an OPENBLAS_CORETYPE the user set is kept.
# Usage: blas_kernels.sh F16RACE_BINARY
set -uo pipefail
bin=$1
fail() { echo "FAIL: $*"; exit 1; }
core_of() { sed -n 's/.*"blas_core": "\([^"]*\)".*/\1/p' | head -n 1; }
out=$(env -u OPENBLAS_CORETYPE "$bin" bench nets --samples 16 --repeats 1 --json 2>&1) || fail "bench nets: $out"
grep -q '"blas_core": "' <<< "$out" || fail "bench nets --json names no blas_core: $out"
core=$(core_of <<< "$out")
if [ -z "$core" ]; then echo "OK (LibTorch's BLAS is not OpenBLAS here)"; exit 0; fi
if grep -qwE 'avx2|avx512f' /proc/cpuinfo && [ "$(tr 'A-Z' 'a-z' <<< "$core")" = prescott ]; then
  fail "OpenBLAS kernels $core on a CPU with AVX2/AVX-512"
fi
out=$(OPENBLAS_CORETYPE=Prescott "$bin" bench nets --samples 16 --repeats 1 --json 2>&1) || fail "bench nets: $out"
[ "$(core_of <<< "$out" | tr 'A-Z' 'a-z')" = prescott ] || fail "the user's OPENBLAS_CORETYPE=Prescott was not kept: $(core_of <<< "$out")"
echo "OK ($core)"
