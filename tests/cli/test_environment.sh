#!/usr/bin/env bash
# Every GoogleTest case ctest runs gets OMP_WAIT_POLICY=PASSIVE and OPENBLAS_NUM_THREADS=1: under
# ctest -j2 on 2 cores, two tests whose idle OpenMP threads spin took 53-56 s where each alone
# takes 1 s (once, a ';' inside gtest_discover_tests' PROPERTIES had silently dropped the
# first). Usage: test_environment.sh BUILD_DIR
set -uo pipefail
cd "$1" || { echo "FAIL: no build folder $1"; exit 1; }
ctest --show-only=json-v1 | python3 -c '
import json, sys
tests = json.load(sys.stdin)["tests"]
gtests = [t for t in tests if any(a.startswith("--gtest_filter=") for a in t.get("command", []))]
if len(gtests) < 100: sys.exit("FAIL: only %d GoogleTest cases found" % len(gtests))
bad = []
for t in gtests:
    env = {}
    for p in t.get("properties", []):
        if p["name"] == "ENVIRONMENT":
            for kv in p["value"]:
                k, _, v = kv.partition("=")
                env[k] = v
        elif p["name"] == "ENVIRONMENT_MODIFICATION":
            for m in p["value"]:
                k, _, rest = m.partition("=")
                op, _, v = rest.partition(":")
                if op == "set": env[k] = v
    if env.get("OMP_WAIT_POLICY") != "PASSIVE" or env.get("OPENBLAS_NUM_THREADS") != "1":
        bad.append(t["name"])
if bad: sys.exit("FAIL: %d of %d cases lack the environment, e.g. %s" % (len(bad), len(gtests), bad[0]))
print("OK: %d GoogleTest cases" % len(gtests))
'
