#!/usr/bin/env bash
# A disk that fills during training (issue 48): on small tmpfs file systems of several sizes, so
# the disk runs out at different writes (a metrics row, a pool snapshot, a checkpoint, a figure),
# the run must stop with exit 2 and one line saying so, keep a LATEST that resumes, and, once
# there is room again, resume to the end with the uninterrupted run's bytes.
# Needs to mount tmpfs (root, or a user namespace that may): otherwise it says so and passes.
# Usage: full_disk.sh F16RACE_BINARY SMOKE_CONFIG WORK_DIR
set -uo pipefail
bin=$1 config=$2 work=$3
fail() { echo "FAIL: $*"; umount "$work/disk" 2>/dev/null; exit 1; }
latest() { echo "$1/checkpoint/$(cat "$1/checkpoint/LATEST" 2>/dev/null)"; }
metrics() { cut -d, -f1-3,6- "$1/metrics.csv"; }
umount "$work/disk" 2>/dev/null
rm -rf "$work" && mkdir -p "$work/disk"
if ! mount -t tmpfs -o size=64k tmpfs "$work/disk" 2>/dev/null; then
  echo "SKIPPED: cannot mount a small tmpfs here (needs root); the full-disk cases of tests/train/test_trainer.cpp still ran"
  exit 0
fi
umount "$work/disk"
args=(--config "$config" --quiet --set train.total_env_steps=2000 --set train.checkpoint_every_updates=3)
"$bin" --threads 1 train "${args[@]}" --run "$work/whole" || fail "the uninterrupted run"
filled=0
for size_k in 700 900 1100 1300 1500 1700; do
  mount -t tmpfs -o size=${size_k}k tmpfs "$work/disk" || fail "mount ${size_k}k"
  run="$work/disk/r"
  out=$("$bin" --threads 1 train "${args[@]}" --run "$run" 2>&1); rc=$?
  if [ $rc -eq 0 ]; then
    echo "${size_k}k: the run fitted"
  else
    [ $rc -eq 2 ] || fail "${size_k}k: exit $rc, expected 2: $out"
    [ "$(echo "$out" | grep -c "error")" -eq 1 ] && [[ "$out" == *"no space left on device"* ]] ||
      fail "${size_k}k: not one line naming the full disk: $out"
    filled=$((filled + 1))
    echo "${size_k}k: $(echo "$out" | grep error | cut -c1-160)"
    mount -o remount,size=16m "$work/disk" || fail "remount"
    "$bin" --threads 1 train --resume "$run" --quiet > "$work/resume.log" 2>&1 ||
      fail "${size_k}k: the run did not resume once there was room: $(tail -n 2 "$work/resume.log")"
  fi
  for f in ll.pt hl.pt; do cmp -s "$(latest "$work/whole")/$f" "$(latest "$run")/$f" || fail "${size_k}k: $f differs"; done
  cmp -s <(metrics "$work/whole") <(metrics "$run") || fail "${size_k}k: metrics.csv differs from the uninterrupted run's"
  umount "$work/disk"
done
[ "$filled" -ge 3 ] || fail "only $filled of 6 sizes filled the disk: the sizes no longer match a run folder"
echo "OK: $filled runs stopped by a full disk, each resumed to the uninterrupted run's bytes"
