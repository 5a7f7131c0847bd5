#!/usr/bin/env bash
# Strangers at a training group's stores (issue 48), on loopback:
#  - while a 2-rank `launch` trains, connections to both of rank 0's ports that do not present the
#    group's token (none, a wrong one, garbage, an HTTP request, silence, a flood of connections)
#    are dropped and each named in one line on rank 0's stderr; the run completes with the same
#    ll.pt, hl.pt and metrics (but wall time) as an undisturbed run;
#  - `ss -ltn` shows both ports bound to 127.0.0.1 only;
#  - a rank with another token is refused (both ranks exit 2, rank 0 names the connection);
#  - a group without a token, and a rank 0 serving other hosts without F16RACE_BIND_ADDR, are
#    refused with one line naming the variable.
# Usage: dist_strangers.sh F16RACE_BINARY SMOKE_CONFIG WORK_DIR
set -euo pipefail
bin=$1 config=$2 work=$3
rm -rf "$work" && mkdir -p "$work"
fail() { echo "FAIL: $*"; exit 1; }
here=$(dirname "$0")
steps=(--set train.total_env_steps=3200)
# Metrics without the wall-time columns (wall_s, samples_per_s).
metrics() { cut -d, -f1-3,6- "$1/metrics.csv"; }
latest() { echo "$1/checkpoint/$(cat "$1/checkpoint/LATEST")"; }
train=("$bin" --threads 1 launch --nproc 2 -- train --config "$config" "${steps[@]}" --quiet)

SECONDS=0
"${train[@]}" --run "$work/calm" > "$work/calm.log" 2>&1 || fail "undisturbed run: $(tail -n 3 "$work/calm.log")"
echo "undisturbed run: $SECONDS s"
! grep -q "dropped a connection" "$work/calm.log" || fail "a member was dropped: $(grep dropped "$work/calm.log")"

# The same run, with strangers at both ports from the moment rank 0 listens.
"${train[@]}" --run "$work/busy" > "$work/busy.log" 2>&1 &
launcher=$!
rank0="" port=""
for _ in $(seq 300); do
  sleep 0.1
  for p in $(pgrep -P $launcher || true); do
    tr '\0' '\n' < /proc/$p/environ 2>/dev/null | grep -qx "RANK=0" && rank0=$p
  done
  [ -n "$rank0" ] && port=$(tr '\0' '\n' < /proc/$rank0/environ | sed -n 's/^MASTER_PORT=//p')
  [ -n "$port" ] && [ "$(ss -ltnH "( sport = :$port or sport = :$((port + 1)) )" | wc -l)" -ge 2 ] && break
done
[ -n "$port" ] || fail "rank 0 never listened (rank 0 '$rank0')"
listening=$(ss -ltnH "( sport = :$port or sport = :$((port + 1)) )" | awk '{print $4}' | sort | tr '\n' ' ')
[ "$listening" = "127.0.0.1:$port 127.0.0.1:$((port + 1)) " ] || fail "rank 0 listens on: $listening"
echo "rank 0 listens on: $listening"
# Rank 1 is paused while the strangers call, so the run outlives them on any machine (on a fast
# one it finished before the flood and the flood was refused): rank 0 waits for it in the
# rendezvous or a collective (the group's 60 s timeout) while its stores serve on their own thread.
rank1=""
for p in $(pgrep -P $launcher || true); do
  tr '\0' '\n' < /proc/$p/environ 2>/dev/null | grep -qx "RANK=1" && rank1=$p
done
[ -n "$rank1" ] || fail "no rank 1 process under the launcher"
kill -STOP "$rank1"
trap 'kill -CONT "$rank1" 2>/dev/null || true' EXIT
python3 "$here/strangers.py" "$port" "$((port + 1))" > "$work/strangers.txt" || fail "strangers.py: $(cat "$work/strangers.txt")"
kill -CONT "$rank1"
set +e
wait $launcher
rc=$?
set -e
[ $rc -eq 0 ] || fail "disturbed run exited $rc: $(tail -n 3 "$work/busy.log")"

# Every stranger (but the flood's, summed up beyond 20 a store) is named, with its own port.
named=0
while read -r store src why; do
  line="f16race: rank 0: dropped a connection from 127.0.0.1:$src to the $store store: no valid group token ($why"
  grep -qF "$line" "$work/busy.log" || fail "no line '$line...': $(grep dropped "$work/busy.log" | head -n 5)"
  named=$((named + 1))
done < <(grep -v '^flood' "$work/strangers.txt")
[ $named -eq 12 ] || fail "strangers.py reported $named named strangers, expected 12"
dropped=$(grep -c "dropped a connection from" "$work/busy.log")
echo "rank 0 named $dropped dropped connections; e.g.: $(grep -m1 "wrong token" "$work/busy.log")"
grep -q "not each named" "$work/busy.log" || true  # the flood's sum comes only if the run outlives its window

for f in ll.pt hl.pt; do
  cmp "$(latest "$work/calm")/$f" "$(latest "$work/busy")/$f" || fail "disturbed run: $f differs from the undisturbed run's"
done
cmp <(metrics "$work/calm") <(metrics "$work/busy") || fail "disturbed run: metrics differ from the undisturbed run's"
echo "the disturbed run ends with the undisturbed run's bytes"

# A rank with another token: refused (exit 2); rank 0 names its connection and how many joined.
p=$((20000 + RANDOM % 12000))  # below the ephemeral range (32768 up)
set +e
WORLD_SIZE=2 RANK=1 MASTER_PORT=$p F16RACE_GROUP_TOKEN=another-token-0123456789 F16RACE_DIST_TIMEOUT=5 \
  "$bin" --threads 1 train --config "$config" --run "$work/two_tokens" --quiet > "$work/tok1.log" 2>&1 &
p1=$!
WORLD_SIZE=2 RANK=0 MASTER_PORT=$p F16RACE_GROUP_TOKEN=the-group-token-0123456789 F16RACE_DIST_TIMEOUT=5 \
  "$bin" --threads 1 train --config "$config" --run "$work/two_tokens" --quiet > "$work/tok0.log" 2>&1
rc0=$?
wait $p1
rc1=$?
set -e
[ $rc0 -eq 2 ] && [ $rc1 -eq 2 ] || fail "two tokens: exit $rc0 / $rc1, expected 2 / 2: $(cat "$work/tok0.log" "$work/tok1.log")"
grep -q "rank 1 of 2: the store at 127.0.0.1:$p refused this rank's group token: give every rank the same F16RACE_GROUP_TOKEN" \
  "$work/tok1.log" || fail "rank 1 with another token: $(cat "$work/tok1.log")"
grep -q "dropped a connection from 127.0.0.1:[0-9]* to the group's store: no valid group token (a wrong token)" "$work/tok0.log" &&
  grep -q "rank 0 of 2: 1 of 2 ranks joined within 5 s" "$work/tok0.log" || fail "rank 0 with a stranger rank: $(cat "$work/tok0.log")"
[ ! -e "$work/two_tokens/metrics.csv" ] || fail "a group of two tokens trained"

# Bad input: one line naming the variable, exit 2.
refused() {  # refused EXPECTED_TEXT ENV... -- (runs a 2-rank train's rank)
  local want=$1 msg rc
  shift
  set +e
  msg=$(env -u F16RACE_GROUP_TOKEN -u F16RACE_GROUP_TOKEN_FILE "$@" "$bin" --threads 1 train --config "$config" \
    --run "$work/refused" --quiet 2>&1)
  rc=$?
  set -e
  [ $rc -eq 2 ] && [ "$(printf '%s\n' "$msg" | wc -l)" -eq 1 ] && [[ "$msg" == *"$want"* ]] || fail "rc $rc: $msg"
}
refused "needs its shared token: set F16RACE_GROUP_TOKEN (or F16RACE_GROUP_TOKEN_FILE)" WORLD_SIZE=2 RANK=1
refused "F16RACE_GROUP_TOKEN holds 5 characters" WORLD_SIZE=2 RANK=1 F16RACE_GROUP_TOKEN=short
refused "set F16RACE_BIND_ADDR (--dist-bind)" WORLD_SIZE=2 RANK=0 MASTER_ADDR=10.11.12.13 \
  F16RACE_GROUP_TOKEN=the-group-token-0123456789
refused "F16RACE_GROUP_TOKEN_FILE=$work/none: cannot read it" WORLD_SIZE=2 RANK=1 F16RACE_GROUP_TOKEN_FILE="$work/none"
[ ! -e "$work/refused" ] || fail "a refused rank made its run folder"
echo "OK"
