#!/usr/bin/env bash
# Issue 48, "every multi-file output appears whole or not at all", as a test. `tournament`,
# `export` and `study` are killed with SIGKILL at random instants while they write over an earlier
# complete output, many times. After each kill the folder must hold the earlier output or the new
# one, whole: the same file names and checksums as one of two reference outputs made beforehand
# (for export: both policies from the same export). A killed study must leave no child running.
# Then a rerun must complete. With a small tmpfs (needs root: skipped with a note otherwise), an
# export and a tournament onto a full disk must leave the earlier output and say so in one line,
# exit 2. The four groups of kills run side by side (each process mostly loads LibTorch, on one
# core), each in its own folders; their reports are printed in order at the end.
# Usage: whole_outputs.sh F16RACE_BINARY CONFIG_DIR WORK_DIR [KILLS_PER_COMMAND]
set -uo pipefail
bin=$(realpath "$1") configs=$(realpath "$2") work=$(realpath -m "$3") kills=${4:-10}
smoke="$configs/smoke.yaml"
umount "$work/full" 2>/dev/null  # left mounted by an interrupted earlier run
rm -rf "$work" && mkdir -p "$work" && cd "$work" || exit 1
fail() {
  echo "FAIL: $*"
  exit 1
}

# A folder's signature: its names and every file's checksum; "absent" when it does not exist.
sig() {
  [ -d "$1" ] || { echo absent; return; }
  (cd "$1" && ls -A | sort && find . -type f -exec md5sum {} + | sort) | md5sum | cut -c1-12
}
now_ms() { date +%s%3N; }
# The kill instants follow the moment a run completes, where the swap happens: a kill that left the
# earlier output moves the next one later, a kill that found the new one moves it earlier, and
# each instant is jittered by +-20 %.
delay_ms=0
adapt_delay() {  # adapt_delay KEPT_OLD(0|1)
  if [ "$1" -eq 1 ]; then delay_ms=$((delay_ms * 5 / 4)); else delay_ms=$((delay_ms * 4 / 5)); fi
}
jittered_delay() { echo "$delay_ms $RANDOM" | awk '{ printf "%.3f", $1 / 1000 * (0.8 + 0.4 * $2 / 32767) }'; }
# Runs a command (a program, not a shell function: the kill must reach it) in the background and
# kills it with SIGKILL after `delay` seconds, if it still runs.
run_and_kill() {  # run_and_kill DELAY PROGRAM ARGS...
  local delay=$1
  shift
  "$@" >/dev/null 2>&1 &
  local pid=$!
  sleep "$delay"
  kill -9 "$pid" 2>/dev/null
  wait "$pid" 2>/dev/null
}
# No process may still run with `pattern` in its command line (a killed study's children).
no_orphans_within() {  # no_orphans_within SECONDS PATTERN
  local deadline=$((SECONDS + $1))
  while pgrep -f -- "$2" >/dev/null; do
    [ "$SECONDS" -lt "$deadline" ] || fail "a killed study left children running: $(pgrep -af -- "$2" | head -3)"
    sleep 0.1
  done
}
png_whole() {  # the signature at the start, the IEND chunk at the end
  [ "$(head -c 8 "$1" | od -An -tx1 | tr -d ' \n')" = "89504e470d0a1a0a" ] &&
    [ "$(tail -c 12 "$1" | od -An -tx1 | tr -d ' \n')" = "0000000049454e44ae426082" ]
}
# Kills `command` at random instants over an earlier output in `folder`, alternating between two
# targets whose complete outputs have signatures sig_a and sig_b. Prints the counts.
kill_trials() {  # kill_trials NAME FOLDER MS SIG_A SIG_B CMD_A... -- CMD_B...
  local name=$1 folder=$2 ms=$3 sig_a=$4 sig_b=$5
  shift 5
  local cmd_a=() cmd_b=()
  while [ "$1" != "--" ]; do cmd_a+=("$1"); shift; done
  shift
  cmd_b=("$@")
  local old=0 new=0 k s before
  delay_ms=$((ms * 3 / 4))
  for k in $(seq 1 "$kills"); do
    before=$(sig "$folder")
    if [ "$before" = "$sig_a" ]; then run_and_kill "$(jittered_delay)" "${cmd_b[@]}"
    else run_and_kill "$(jittered_delay)" "${cmd_a[@]}"; fi
    s=$(sig "$folder")
    [ "$s" = "$sig_a" ] || [ "$s" = "$sig_b" ] ||
      fail "$name: kill $k left $folder neither the earlier output nor the new one: $(ls -A "$folder" | tr '\n' ' ')"
    if [ "$s" = "$before" ]; then old=$((old + 1)); adapt_delay 1; else new=$((new + 1)); adapt_delay 0; fi
  done
  echo "$name: $kills kills with SIGKILL: $old left the earlier output, $new the new one, each whole (at $((($(now_ms) - start) / 1000)) s)"
}
# The stale staging folders beside `folder` are gone once a run over it has completed.
no_staging_left() {  # no_staging_left FOLDER
  local left
  left=$(ls -A "$(dirname "$1")" | grep -c "^\.$(basename "$1")\.")
  [ "$left" -eq 0 ] || fail "$left staging folders of killed runs left beside $1: $(ls -A "$(dirname "$1")" | tr '\n' ' ')"
}

start=$(now_ms)
"$bin" train --config "$smoke" --run runA --max-updates 2 --quiet >/dev/null &
a=$!
"$bin" train --config "$smoke" --run runB --seed 4 --max-updates 2 --quiet >/dev/null || fail "setup: run B"
wait $a || fail "setup: run A"
T() { "$bin" tournament --runs runA --races "$1" --batch 4 --bootstrap 100 --out "$2"; }
E() { "$bin" export --run "$1" --out "$2"; }
for races in 2 4; do
  printf 'base_config: %s\nvariants: [es_d3]\nseeds: [1]\ndt_hl_s: [2]\ntotal_env_steps: 1000\njobs: 1\nraces_per_pair: %s\ncontrols: false\n' \
    "$smoke" "$races" > "study$races.yaml"
done
# Absolute folders: the children's command lines name them, which no_orphans_within looks for.
S() { "$bin" study --config "study$1.yaml" --out "$work/$2"; }

# --- tournament: 2 or 4 races per pair over runA ---------------------------------------------------
tournament_kills() {
  local t0 t_ms st2 st4
  t0=$(now_ms)
  T 2 ref_t2 >/dev/null || fail "reference tournament (2 races)"
  t_ms=$(($(now_ms) - t0))
  T 4 ref_t4 >/dev/null || fail "reference tournament (4 races)"
  for f in races.csv pairings.csv summary.json summary.md tournament.png pairings.png done.txt; do
    [ -s "ref_t2/$f" ] || fail "reference tournament without $f"
  done
  png_whole ref_t2/tournament.png || fail "reference tournament.png is not a whole PNG"
  grep -q "^figures: drawn$" ref_t2/done.txt || fail "reference tournament's done.txt: $(cat ref_t2/done.txt)"
  st2=$(sig ref_t2) st4=$(sig ref_t4)
  [ "$st2" != "$st4" ] || fail "the two reference tournaments are the same"
  cp -a ref_t2 tour
  kill_trials tournament tour "$t_ms" "$st2" "$st4" "$bin" tournament --runs runA --races 2 --batch 4 --bootstrap 100 \
    --out tour -- "$bin" tournament --runs runA --races 4 --batch 4 --bootstrap 100 --out tour
  T 4 tour >/dev/null || fail "tournament rerun"
  [ "$(sig tour)" = "$st4" ] || fail "tournament rerun differs from its reference"
  no_staging_left tour
}

# --- export: run A's or run B's policies ------------------------------------------------------------
export_kills() {
  local t0 e_ms sea seb msg
  t0=$(now_ms)
  E runA ref_ea >/dev/null || fail "reference export A"
  e_ms=$(($(now_ms) - t0))
  E runB ref_eb >/dev/null || fail "reference export B"
  sea=$(sig ref_ea) seb=$(sig ref_eb)
  cmp -s ref_ea/hl_policy.pt ref_eb/hl_policy.pt && fail "runs A and B export the same HL policy"
  cmp -s ref_ea/ll_policy.pt ref_eb/ll_policy.pt && fail "runs A and B export the same LL policy"
  cp -a ref_ea exp
  kill_trials export exp "$e_ms" "$sea" "$seb" "$bin" export --run runA --out exp -- "$bin" export --run runB --out exp
  E runB exp >/dev/null || fail "export rerun"
  [ "$(sig exp)" = "$seb" ] || fail "export rerun differs from its reference"
  no_staging_left exp
  # A folder that holds anything else is refused before anything is written.
  mkdir -p foreign && echo notes > foreign/notes.md
  msg=$(E runA foreign 2>&1 >/dev/null)
  [ $? -eq 2 ] && [[ "$msg" == *"foreign: holds notes.md, not export output"* ]] || fail "export over other files: $msg"
  [ "$(ls -A foreign)" = "notes.md" ] || fail "export over other files changed the folder"
}

# --- study: one cell, its tournament at 2 or 4 races per pair ---------------------------------------
report_whole() {
  [ "$(ls -A study/report | tr '\n' ' ')" = "curves_dt2.gp curves_dt2.png report.md " ] ||
    fail "study report folder not whole: $(ls -A study/report | tr '\n' ' ')"
  png_whole study/report/curves_dt2.png || fail "study report: curves_dt2.png is not a whole PNG"
  grep -Eq "^[24] races per pair" study/report/report.md || fail "study report without its tournament"
}
study_kills() {
  local t0 s_ms ss2 ss4 old=0 new=0 k s before races
  S 4 study >/dev/null || fail "first study (trains its cell)"
  ss4=$(sig study/dt2/tournament)
  t0=$(now_ms)
  S 2 study >/dev/null || fail "study at 2 races per pair"
  s_ms=$(($(now_ms) - t0))
  ss2=$(sig study/dt2/tournament)
  echo "$ss2" > study_sig2
  [ "$ss2" != "$ss4" ] || fail "the study's two tournaments are the same"
  report_whole
  delay_ms=$((s_ms * 3 / 4))
  for k in $(seq 1 "$kills"); do
    before=$(sig study/dt2/tournament)
    if [ "$before" = "$ss2" ]; then races=4; else races=2; fi
    run_and_kill "$(jittered_delay)" "$bin" study --config "study$races.yaml" --out "$work/study"
    no_orphans_within 10 "$work/study/"
    s=$(sig study/dt2/tournament)
    [ "$s" = "$ss2" ] || [ "$s" = "$ss4" ] ||
      fail "study: kill $k left its tournament neither old nor new: $(ls -A study/dt2/tournament | tr '\n' ' ')"
    report_whole
    if [ "$s" = "$before" ]; then old=$((old + 1)); adapt_delay 1; else new=$((new + 1)); adapt_delay 0; fi
  done
  echo "study: $kills kills with SIGKILL while racing or reporting: $old left the earlier tournament, $new the new" \
    "one, each whole; no child outlived the study (at $((($(now_ms) - start) / 1000)) s)"
  S 2 study >/dev/null || fail "study rerun"
  [ "$(sig study/dt2/tournament)" = "$ss2" ] || fail "study rerun's tournament differs"
  report_whole
}

# Killed while training: the training child stops with the study (no orphan), and the rerun is not
# refused; the resumed run races the very same tournament (compared at the end with study_kills').
# Each kill waits for a training to run.
training_kills() {
  local with_child=0 k pid rc
  # First, while the cell is surely unfinished: SIGTERM is forwarded, the training checkpoints and
  # stops, and the study waits for it and exits 130.
  "$bin" study --config study2.yaml --out "$work/fresh" > term.log 2>&1 &
  pid=$!
  for _ in $(seq 1 300); do pgrep -f -- "train.*$work/fresh/" >/dev/null && break; sleep 0.05; done
  kill -TERM "$pid"
  wait "$pid"
  rc=$?
  [ "$rc" -eq 130 ] || fail "a study stopped by SIGTERM exited $rc: $(tail -2 term.log)"
  pgrep -f -- "$work/fresh/" >/dev/null && fail "a study stopped by SIGTERM exited before its children"
  for k in 1 2 3; do
    "$bin" study --config study2.yaml --out "$work/fresh" >/dev/null 2>&1 &
    pid=$!
    for _ in $(seq 1 300); do pgrep -f -- "train.*$work/fresh/" >/dev/null && break; sleep 0.05; done
    pgrep -f -- "train.*$work/fresh/" >/dev/null && with_child=$((with_child + 1))
    sleep "$(echo "$k $RANDOM" | awk '{ printf "%.3f", 0.3 * $1 * $2 / 32767 }')"
    kill -9 "$pid" 2>/dev/null
    wait "$pid" 2>/dev/null
    no_orphans_within 20 "$work/fresh/"
  done
  [ "$with_child" -ge 1 ] || fail "no kill found the study training"
  S 2 fresh > fresh.log 2>&1 || fail "study rerun after kills while training: $(tail -3 fresh.log)"
  echo "study: 3 kills with SIGKILL, $with_child while its training ran: it stopped with the study each time;" \
    "SIGTERM: the study waited for its training and exited 130; the rerun completed (at $((($(now_ms) - start) / 1000)) s)"
}

tournament_kills > tournament.out 2>&1 &
jobs_t=$!
export_kills > export.out 2>&1 &
jobs_e=$!
study_kills > study.out 2>&1 &
jobs_s=$!
training_kills > training.out 2>&1 &
jobs_f=$!
failed=0
for j in $jobs_t $jobs_e $jobs_s $jobs_f; do wait "$j" || failed=1; done
cat tournament.out export.out study.out training.out
[ "$failed" -eq 0 ] || exit 1
[ "$(sig fresh/dt2/tournament)" = "$(cat study_sig2)" ] || fail "the study killed while training raced another tournament"
sea=$(sig ref_ea) st2=$(sig ref_t2)

# --- full disk ----------------------------------------------------------------------------------------
mkdir -p full
if mount -t tmpfs -o size=6m tmpfs full 2>/dev/null; then
  trap 'umount "$work/full" 2>/dev/null' EXIT
  trap 'exit 1' INT TERM
  cp -a ref_ea full/exp && cp -a ref_t2 full/tour || fail "the earlier outputs do not fit the 6 MB tmpfs"
  head -c 100M /dev/zero > full/filler 2>/dev/null
  for what in export tournament; do
    if [ $what = export ]; then msg=$(E runB full/exp 2>&1 >/dev/null); else msg=$(T 4 full/tour 2>&1 >/dev/null); fi
    rc=$?
    [ "$rc" -eq 2 ] && [ "$(printf '%s\n' "$msg" | grep -c .)" -eq 1 ] && [[ "${msg,,}" == *"no space left on device"* ]] ||
      fail "$what onto a full disk: rc $rc: $msg"
    echo "$what onto a full disk: $msg"
  done
  [ "$(sig full/exp)" = "$sea" ] || fail "export onto a full disk changed the earlier export"
  [ "$(sig full/tour)" = "$st2" ] || fail "tournament onto a full disk changed the earlier tournament"
  [ "$(ls -A full | tr '\n' ' ')" = "exp filler tour " ] || fail "a full disk left temporaries: $(ls -A full)"
  # A disk that fills while gnuplot draws (the data files fit, the figure does not): either the new
  # output whole with its figures, or exit 2 in one line with the earlier output kept; never an
  # output without its figures (gnuplot exits 0 with a PNG cut short).
  rm -f full/filler
  "$bin" replay --run runA --out full/rep --seed 1 > /dev/null 2>&1 || fail "reference replay on the tmpfs"
  srep=$(sig full/rep)
  for free_kb in 40 80 140 200 300; do
    rm -f full/filler
    avail_kb=$(df -k --output=avail full | tail -n 1 | tr -d ' ')
    [ "$avail_kb" -gt "$free_kb" ] && head -c "$(((avail_kb - free_kb) * 1024))" /dev/zero > full/filler 2>/dev/null
    for what in tournament replay; do
      if [ $what = tournament ]; then out=$(T 4 full/tour 2>&1); else out=$("$bin" replay --run runA --out full/rep --seed 2 2>&1); fi
      rc=$?
      d=full/tour old=$st2 png=tournament.png
      [ $what = replay ] && d=full/rep old=$srep png=replay.png
      if [ $rc -eq 0 ]; then
        png_whole "$d/$png" || fail "$what with $free_kb KB free exited 0 without a whole $png: $out"
        grep -q "not drawn" <<< "$out" && fail "$what with $free_kb KB free exited 0 with a figure not drawn: $out"
        # the new output stays for the next size; its earlier one is the reference again
        if [ $what = tournament ]; then rm -rf full/tour && cp -a ref_t2 full/tour; else
          rm -rf full/rep && "$bin" replay --run runA --out full/rep --seed 1 > /dev/null 2>&1; fi
      else
        msg=$(grep -v '^ *[0-9]*%' <<< "$out" | grep -v "^resuming\|^tournament:" | tail -n 1)
        [ $rc -eq 2 ] && [[ "${msg,,}" == *"no space left on device"* ]] ||
          fail "$what with $free_kb KB free: rc $rc: $out"
        [ "$(sig $d)" = "$old" ] || fail "$what with $free_kb KB free changed the earlier output"
        echo "$what with $free_kb KB free: $msg"
      fi
    done
  done
  rm -f full/filler
  umount full && trap - EXIT
else
  echo "full-disk case skipped: cannot mount a tmpfs here (needs root)"
fi
echo "OK: whole outputs after $((3 * kills + 3)) kills in $((($(now_ms) - start) / 1000)) s"
