#!/usr/bin/env bash
# A policy-only run folder of one self-play pool snapshot, so that `tournament`, `replay` and
# `export` race the networks a run had at that step (notebook 81: the low level's learning curve).
#
#   experiments/scripts/pool_snapshot_run.sh RUN STEP OUT
#
# RUN is a run folder, STEP a name under RUN/pool/ (e.g. step_0002234784), OUT a new folder:
# RUN's config.yaml, and a checkpoint holding the snapshot's hl.pt and ll.pt with the run's config
# hash (a snapshot has no optimiser or normaliser state of its own: the networks carry theirs) and
# no tail members, so its high level is the one tail the snapshot holds.
set -euo pipefail
[ $# -eq 3 ] || { echo "usage: experiments/scripts/pool_snapshot_run.sh RUN STEP OUT" >&2; exit 2; }
run="$1" step="$2" out="$3"
[ -f "$run/pool/$step/ll.pt" ] && [ -f "$run/pool/$step/hl.pt" ] ||
  { echo "$run/pool/$step: no snapshot there (ls $run/pool)" >&2; exit 2; }
latest="$run/checkpoint/$(cat "$run/checkpoint/LATEST" 2>/dev/null)"
[ -f "$latest/meta.yaml" ] || { echo "$run: no checkpoint/LATEST to read the config hash from" >&2; exit 2; }
[ ! -e "$out" ] || { echo "$out: exists; give a new folder" >&2; exit 2; }
steps="${step#step_}"
[[ "$steps" =~ ^[0-9]+$ ]] || { echo "$step: expected step_<env steps>" >&2; exit 2; }
ck="$out.tmp/checkpoint/${step}_u0"
mkdir -p "$ck"
cp "$run/config.yaml" "$out.tmp/"
cp "$run/pool/$step/hl.pt" "$run/pool/$step/ll.pt" "$ck/"
printf 'format: 3\nconfig_hash: %s\nenv_steps: %d\nupdates: 0\npolicy_only: true\n' \
  "$(awk '/^config_hash:/ {print $2}' "$latest/meta.yaml")" "$((10#$steps))" > "$ck/meta.yaml"
echo "${step}_u0" > "$out.tmp/checkpoint/LATEST"
mv "$out.tmp" "$out"  # whole or not at all
