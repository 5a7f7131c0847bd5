#!/usr/bin/env bash
# The golden bytes: a short run of the default config (the whole recipe in miniature: 14 bilevel
# updates, then 7 of the high level alone on each of three tails), a small tournament of it against its
# controls and the autopilot, and one replay, hashed and compared with the hashes committed in
# tests/data/golden_bytes.txt. In the reproducible mode those are the bytes of every x86-64 CPU
# with AVX2 and FMA, so this test fails on the first CPU that computes otherwise. A change meant to
# change the bytes regenerates the file on purpose (--write) and says why in its commit.
# Usage: golden_bytes.sh F16RACE_BINARY SOURCE_DIR WORK_DIR [--write]
set -uo pipefail
bin=$(realpath "$1") src=$(realpath "$2") work=$(realpath -m "$3") write=${4:-}
golden="$src/tests/data/golden_bytes.txt"
rm -rf "$work" && mkdir -p "$work" && cd "$work" || exit 1
fail() { echo "FAIL: $*"; exit 1; }

mode=$("$bin" --version | sed -n 's/^numerics: \([a-z]*\).*/\1/p')
if [ "$mode" != reproducible ]; then
  echo "OK (a $mode build: its bytes are this CPU's own; the golden bytes are the reproducible mode's)"
  exit 0
fi

"$bin" --threads 2 train --config "$src/configs/default.yaml" --set train.total_env_steps=40000 --run "$work/run" \
  --quiet > train.log 2>&1 || fail "train: $(tail -n 3 train.log)"
"$bin" --threads 2 tournament --runs "$work/run" --controls --with-autopilot --races 8 --out "$work/tour" \
  > tour.log 2>&1 || fail "tournament: $(tail -n 3 tour.log)"
"$bin" --threads 2 replay --run "$work/run" --opponent autopilot --out "$work/replay" > replay.log 2>&1 ||
  fail "replay: $(tail -n 3 replay.log)"

# One line per file of the run folder and its members: its sha256 and its path. Left out: what
# records the moment (.lock a pid, wall_s.txt the time) and the figures (curves.*: gnuplot's PNG encoder is not the project's); metrics.csv
# without its wall-time columns (wall_s, samples_per_s).
run_hashes() {
  (cd run && find . -type f ! -name .lock ! -name wall_s.txt ! -name 'curves*' \
     ! -name metrics.csv | sed 's|^\./||' | LC_ALL=C sort | xargs sha256sum
   find . -name metrics.csv | sed 's|^\./||' | LC_ALL=C sort | while read -r m; do
     echo "$(cut -d, -f1-3,6- "$m" | sha256sum | cut -d' ' -f1)  $m (less wall_s, samples_per_s)"
   done)
}
{
  run_hashes
  (cd tour && sha256sum races.csv pairings.csv summary.json summary.md | sed 's|  |  tour/|')
  (cd replay && ls replay_agent*.csv | LC_ALL=C sort | xargs sha256sum replay_goals.csv replay.md replay.acmi |
     sed 's|  |  replay/|')
} > hashes.txt

if [ "$write" = --write ]; then
  { echo "# Golden bytes of the reproducible mode (tests/cli/golden_bytes.sh); regenerate with --write only when"
    echo "# a change is meant to change them, and say why in the commit. Written on $(sed -n 's/^model name.*: //p' /proc/cpuinfo | head -n 1)."
    cat hashes.txt; } > "$golden"
  echo "written: $golden ($(wc -l < hashes.txt) files)"
  exit 0
fi
[ -f "$golden" ] || fail "no $golden: write it with $0 BINARY SOURCE_DIR WORK_DIR --write"
if ! diff <(grep -v '^#' "$golden") hashes.txt > diff.txt; then
  fail "$(grep -c '^>' diff.txt) of $(wc -l < hashes.txt) files differ from the golden bytes on $(sed -n \
    's/^model name.*: //p' /proc/cpuinfo | head -n 1): $(grep '^>' diff.txt | head -n 5 | awk '{print $3, $4}' | tr '\n' ' ')"
fi
echo "OK ($(wc -l < hashes.txt) files, the golden bytes)"
