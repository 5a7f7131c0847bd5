#!/usr/bin/env bash
# Issue 18's test (a) over Gloo on loopback: two ranks of replicas_over_gloo (see its source).
# Usage: replicas_over_gloo.sh REPLICAS_OVER_GLOO_BINARY
set -euo pipefail
bin=$1
port=$((20000 + RANDOM % 12000))  # below the ephemeral range (32768 up), which connections take
export WORLD_SIZE=2 MASTER_ADDR=127.0.0.1 MASTER_PORT=$port F16RACE_DIST_TIMEOUT=30
export F16RACE_GROUP_TOKEN="replicas-over-gloo-$RANDOM-$RANDOM"  # the group's shared token, as launch sets one
RANK=1 "$bin" > /dev/null &
rank1=$!
set +e
RANK=0 "$bin"
rc0=$?
wait $rank1
rc1=$?
set -e
[ $rc0 -eq 0 ] && [ $rc1 -eq 0 ] || { echo "FAIL: rank 0 exit $rc0, rank 1 exit $rc1"; exit 1; }
