# Sourced by the dist_*.sh tests (which define `fail`): lose rank 1 of a running group.
#
# lose_rank1 SIG READY_PATH LOG -- COMMAND...
#   starts COMMAND (an `f16race launch --nproc 2 ...` line) in the background, its output in LOG;
#   once rank 1 runs and READY_PATH exists (the group is under way), sends SIG (KILL: the rank
#   dies; STOP: it hangs) to rank 1 and waits for the launcher. Fails unless the group exits
#   non-zero within 30 s with rank 0's one line naming rank 1. Sets `took`: seconds from the
#   signal to the group's end.
lose_rank1() {
  local sig=$1 ready=$2 log=$3
  shift 4
  "$@" > "$log" 2>&1 &
  local launcher=$! victim="" rc start p
  for _ in $(seq 300); do
    sleep 0.1
    for p in $(pgrep -P $launcher || true); do
      tr '\0' '\n' < /proc/$p/environ 2>/dev/null | grep -qx "RANK=1" && victim=$p
    done
    [ -n "$victim" ] && [ -e "$ready" ] && break
  done
  [ -n "$victim" ] && [ -e "$ready" ] || fail "$sig: the group never got under way (rank 1 '$victim', $ready)"
  sleep 1
  start=$(date +%s)
  kill -"$sig" "$victim"
  set +e
  wait $launcher
  rc=$?
  set -e
  kill -KILL "$victim" 2>/dev/null || true
  took=$(( $(date +%s) - start ))
  [ $rc -ne 0 ] || fail "$sig: the group exited 0 after losing rank 1"
  grep -q "rank 0 of 2: rank 1 is not running" "$log" || fail "$sig: no line naming rank 1: $(tail -n 4 "$log")"
  [ $took -lt 30 ] || fail "$sig: the group took $took s to stop"
}
