#!/usr/bin/env bash
# The reproducible mode's promise on the machine at hand: a short run trained, then raced in a
# tournament and replayed, under every choice the CPU-dependent layers could make here (OpenBLAS's
# kernel sets, LibTorch's capability levels, oneDNN's instruction set, glibc's CPU tunables, one
# or two threads) gives the same bytes as without them. A native build has no such promise: there
# the test checks only that the build says so and records it in the run folder.
# Usage: numeric_modes.sh F16RACE_BINARY CONFIG_DIR WORK_DIR
set -uo pipefail
bin=$(realpath "$1") configs=$(realpath "$2") work=$(realpath -m "$3")
rm -rf "$work" && mkdir -p "$work" && cd "$work" || exit 1
fail() { echo "FAIL: $*"; exit 1; }

mode=$("$bin" --version | sed -n 's/^numerics: \([a-z]*\).*/\1/p')
[ -n "$mode" ] || fail "--version names no numeric mode: $("$bin" --version)"

# The bytes of a run folder that do not depend on wall time: checkpoints, pool, config, and
# metrics.csv without its wall_s and samples_per_s columns.
run_bytes() {
  (cd "$1" && find checkpoint pool members -type f ! -name wall_s.txt 2>/dev/null | sort | xargs md5sum
   md5sum config.yaml
   cut -d, -f1-3,6- metrics.csv | md5sum) | md5sum | cut -c1-16
}
out_bytes() { (cd "$1" && md5sum races.csv pairings.csv summary.json) | md5sum | cut -c1-16; }

train() {  # train NAME [ENV=VALUE...] -- F16RACE OPTIONS...
  local name=$1; shift
  local envs=()
  while [ "$1" != -- ]; do envs+=("$1"); shift; done; shift
  # Every case's run is named "run": the tournament and replay write the run's name.
  local d="$work/$name"
  mkdir -p "$d"
  env "${envs[@]}" "$bin" "$@" train --config "$configs/smoke.yaml" --run "$d/run" --quiet > "$d/train.log" 2>&1 ||
    fail "train $name (${envs[*]} $*): $(tail -n 3 "$d/train.log")"
  env "${envs[@]}" "$bin" "$@" tournament --runs "$d/run" --controls --with-autopilot --races 4 --out "$d/tour" \
    > "$d/tour.log" 2>&1 || fail "tournament $name: $(tail -n 3 "$d/tour.log")"
  env "${envs[@]}" "$bin" "$@" replay --run "$d/run" --out "$d/replay" --seed 2 > "$d/replay.log" 2>&1 ||
    fail "replay $name: $(tail -n 3 "$d/replay.log")"
  echo "$(run_bytes "$d/run") $(out_bytes "$d/tour") $(cd "$d/replay" &&
    cat replay_agent*.csv replay_goals.csv replay.md replay.acmi | md5sum | cut -c1-16)"
}

base=$(train base -- --threads 2)
meta=$(ls base/run/checkpoint/*/meta.yaml)
grep -q "^numerics: $mode$" $meta || fail "the checkpoint does not record mode $mode: $(cat $meta)"
if [ "$mode" = native ]; then grep -q "^cpu: " $meta || fail "a native checkpoint does not name its CPU: $(cat $meta)"
else grep -q "^cpu: " $meta && fail "a reproducible checkpoint names a CPU: $(cat $meta)"; fi
if [ "$mode" = native ]; then
  echo "OK (native build: its bytes are this CPU's own, recorded in the run folder; nothing more to compare)"
  exit 0
fi

# Each alternative alone, so that a difference names its layer.
checked=0
while read -r name opts; do
  # shellcheck disable=SC2086
  got=$(train "$name" $opts)
  [ "$got" = "$base" ] || fail "$name ($opts) gave other bytes than the plain run: $got against $base"
  checked=$((checked + 1))
done <<'EOF'
threads1 -- --threads 1
threads3 -- --threads 3
blas_skylakex OPENBLAS_CORETYPE=SkylakeX -- --threads 2
blas_zen OPENBLAS_CORETYPE=Zen -- --threads 2
blas_prescott OPENBLAS_CORETYPE=Prescott GOTO_BLOCK_FACTOR=50 -- --threads 2
aten_default ATEN_CPU_CAPABILITY=default -- --threads 2
aten_avx512 ATEN_CPU_CAPABILITY=avx512 -- --threads 1
onednn_sse41 DNNL_MAX_CPU_ISA=SSE41 ONEDNN_MAX_CPU_ISA=SSE41 -- --threads 2
glibc_hwcaps GLIBC_TUNABLES=glibc.cpu.hwcaps=-AVX2,-FMA,-AVX512F -- --threads 2
EOF

# The pins hold where they are read: OpenBLAS reports its Haswell set whatever the user set.
core=$(OPENBLAS_CORETYPE=SkylakeX "$bin" bench nets --samples 16 --repeats 1 --json 2>&1 |
       sed -n 's/.*"blas_core": "\([^"]*\)".*/\1/p' | head -n 1)
[ "$(tr 'A-Z' 'a-z' <<< "$core")" = haswell ] || fail "OPENBLAS_CORETYPE=SkylakeX was not pinned to Haswell: '$core'"
# A run continues only in its own mode: a native run (or one from before the record, which was
# native) is refused by `train --resume` in one line, exit 2, its files untouched.
sig() { (cd "$1" && find . -type f ! -name .lock | LC_ALL=C sort | xargs md5sum) | md5sum; }
for kind in native legacy; do
  cp -r base/run "$kind"
  for m in $kind/checkpoint/*/meta.yaml $kind/pool/*/meta.yaml; do
    [ -f "$m" ] || continue
    if [ $kind = native ]; then sed -i 's/^numerics: .*/numerics: native\ncpu: "Another CPU (family 6 model 85)"/' "$m"
    else sed -i '/^numerics: /d' "$m"; fi
  done
  before=$(sig $kind)
  out=$("$bin" train --resume "$work/$kind" 2>&1); rc=$?
  [ $rc -eq 2 ] || fail "train --resume of a $kind run exited $rc, not 2: $out"
  [ "$(wc -l <<< "$out")" -eq 1 ] || fail "the refusal of a $kind run is not one line: $out"
  grep -q "would mix two modes' kernels in one run; resume it with a native build" <<< "$out" ||
    fail "the refusal of a $kind run does not say why and what to do: $out"
  [ "$(sig $kind)" = "$before" ] || fail "the refused resume changed the $kind run's files"
done
grep -q "before the mode was recorded" <<< "$("$bin" train --resume "$work/legacy" 2>&1)" ||
  fail "the refusal of a run without a numerics record does not say it predates the record"
# A tournament of runs from different modes races them, and says so first and in summary.md.
out=$("$bin" tournament --runs "$work/base/run" "$work/native" --races 2 --out "$work/mixed" 2>&1) ||
  fail "a tournament of a reproducible and a native run: $out"
head -n 1 <<< "$out" | grep -q "^tournament: warning: the runs were trained in different numeric modes" ||
  fail "the tournament's first line does not flag the modes: $(head -n 1 <<< "$out")"
grep -q "^\*\*Numeric modes differ\*\*: .*native on Another CPU (family 6 model 85)" mixed/summary.md ||
  fail "summary.md does not flag the modes"
cp -r threads1/run twin  # the same bytes as base/run, under another name
out=$("$bin" tournament --runs "$work/base/run" "$work/twin" --races 2 --out "$work/same" 2>&1) ||
  fail "a tournament of two reproducible runs: $out"
grep -q "numeric modes" <<< "$out$(cat same/summary.md)" && fail "two reproducible runs were flagged as mixed"

echo "OK ($checked alternatives, the same bytes as the plain run: $base)"
