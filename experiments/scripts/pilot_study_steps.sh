# The steps that experiments/scripts/study_block.sh, scaling_piece.sh and duel_piece.sh share: a study on one
# frozen pilot, configured from a template, trained, and each run raced against its own controls.
# Sourced, not run; the caller sets `here` (the repository's root).

# pilot_study_binary PILOT: sets bin (F16RACE, default build/f16race) and threads
# (F16RACE_THREADS, default 2); refuses a PILOT that is not a trained run (exit 2).
pilot_study_binary() {
  bin="$(realpath "${F16RACE:-$here/build/f16race}")"
  threads="${F16RACE_THREADS:-2}"
  [ -f "$1/checkpoint/LATEST" ] || { echo "$1: not a trained run (no checkpoint/LATEST)" >&2; exit 2; }
}

# pilot_study_config TEMPLATE CONFIG SED_SCRIPT DESCRIPTION: writes CONFIG as TEMPLATE edited by
# SED_SCRIPT, unless CONFIG holds other bytes already (a piece started with another pilot or
# config: refused, exit 2, so a resumed study never mixes two configs).
pilot_study_config() {
  local template="$1" config="$2" script="$3" what="$4"
  sed "$script" "$template" > "$config.new"
  if [ -f "$config" ] && ! cmp -s "$config" "$config.new"; then
    rm "$config.new"
    echo "$config: this $what was started with another pilot or config; give another OUT_DIR" >&2
    exit 2
  fi
  mv "$config.new" "$config"
}

# pilot_study_controls BIN THREADS RUN...: each RUN against its own @center and @random, 512 races
# on configs/long.yaml's tracks, into RUN's study folder's controls/NAME (kept once done.txt is there).
pilot_study_controls() {
  local bin="$1" threads="$2" run o
  shift 2
  for run in "$@"; do
    o="$(dirname "$run")/controls/$(basename "$run")"
    [ -f "$o/done.txt" ] || "$bin" --threads "$threads" tournament --runs "$run" --controls --no-untrained \
      --races 512 --seed 1 --tracks configs/long.yaml --out "$o"
  done
}
