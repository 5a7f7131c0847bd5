# Sourced by the dist_*.sh tests (which define `fail` and `bin`): a group's ranks that differ, and a
# rank lost from a running group.
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
  # The launcher's port pair lies outside the ephemeral range (whose ports any connection may take).
  local port lo hi
  port=$(tr '\0' '\n' < /proc/$victim/environ | sed -n 's/^MASTER_PORT=//p')
  read -r lo hi < /proc/sys/net/ipv4/ip_local_port_range
  [ -n "$port" ] && { [ $((port + 1)) -lt "$lo" ] || [ "$port" -gt "$hi" ]; } ||
    fail "$sig: the launcher chose MASTER_PORT '$port', inside the ephemeral range [$lo, $hi]"
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

# refused_pair LOG_PREFIX RANK0_ARGS RANK1_ARGS
#   starts rank 0 and rank 1 of a group of two, each `$bin --threads 1` with the arguments of the
#   array named RANK0_ARGS / RANK1_ARGS (they differ), outputs in LOG_PREFIX0.log / LOG_PREFIX1.log.
#   Fails unless both are refused at the start (exit 2) with the line naming rank 1's difference.
refused_pair() {
  local prefix=$1
  local -n args0=$2 args1=$3
  local port=$((20000 + RANDOM % 12000)) p1 rc0 rc1  # below the ephemeral range (32768 up)
  local -x F16RACE_GROUP_TOKEN="refused-pair-$RANDOM-$RANDOM-$RANDOM"  # what launch would set
  set +e
  WORLD_SIZE=2 RANK=1 MASTER_PORT=$port "$bin" --threads 1 "${args1[@]}" > "${prefix}1.log" 2>&1 &
  p1=$!
  WORLD_SIZE=2 RANK=0 MASTER_PORT=$port "$bin" --threads 1 "${args0[@]}" > "${prefix}0.log" 2>&1
  rc0=$?
  wait $p1
  rc1=$?
  set -e
  [ $rc0 -eq 2 ] && [ $rc1 -eq 2 ] || fail "mismatched ranks: exit $rc0 / $rc1, expected 2 / 2"
  local r
  for r in 0 1; do
    grep -q "rank 1 runs another command or build than rank 0" "${prefix}$r.log" || fail "rank $r: $(cat "${prefix}$r.log")"
  done
}
