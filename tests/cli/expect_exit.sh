#!/usr/bin/env bash
# Runs a command and checks its exit status; for the tests ctest judges by an output pattern
# (PASS_REGULAR_EXPRESSION ignores the status). With the expected status the command's output
# passes through for the pattern; with another, only a FAIL line, so the pattern cannot match.
# Usage: expect_exit.sh STATUS -- COMMAND [ARGS...]
set -uo pipefail
want=$1
[ "${2:-}" = -- ] || { echo "usage: expect_exit.sh STATUS -- COMMAND [ARGS...]"; exit 1; }
shift 2
out=$("$@" 2>&1)
rc=$?
if [ "$rc" -ne "$want" ]; then
  echo "FAIL: exit status $rc, expected $want (output withheld so that the test's pattern cannot pass)"
  exit 1
fi
printf '%s\n' "$out"
