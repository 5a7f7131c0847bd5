#!/usr/bin/env bash
# Every `bench ... --json` line is JSON a parser reads, also when a string in it (the config
# path) holds a quote, a backslash or a tab: strings go through io::json_string.
# Usage: bench_json.sh F16RACE_BINARY CONFIGS_DIR
set -uo pipefail
bin=$1
configs=$2
fail() { echo "FAIL: $*"; exit 1; }
dir=$(mktemp -d)
trap 'rm -rf "$dir"' EXIT
weird="$dir/"$'we"ird\\ta\tb.yaml'
cp "$configs/default.yaml" "$weird" || fail "cannot copy the config"
check() {  # $1: what, stdin: the bench's output; every line starting with { must parse
  python3 -c '
import json, shutil, sys
what, want = sys.argv[1], sys.argv[2]
lines = [l for l in sys.stdin.read().splitlines() if l.startswith("{")]
if not lines: sys.exit(what + ": no JSON line")
for l in lines:
    try: j = json.loads(l)
    except ValueError as e: sys.exit(what + ": not JSON (" + str(e) + "): " + l)
    if want and j.get("config") != want: sys.exit(what + ": config " + repr(j.get("config")) + " != " + repr(want))
    if j.get("bench") == "fma_peak":  # the roofline: the widest vectors this CPU has, both precisions measured
        flags = open("/proc/cpuinfo").read().split()
        isa = "avx512" if "avx512f" in flags else "avx2" if "avx2" in flags and "fma" in flags else "sse2"
        if j.get("isa") != isa: sys.exit(what + ": fma_peak isa " + repr(j.get("isa")) + " on a CPU with " + isa)
        if not (j["f32_gflops"] > 0 and j["f64_gflops"] > 0): sys.exit(what + ": fma_peak " + l)
    if j.get("bench") == "nets" and "fma_peak_gflops" in j:  # every network read against the peak printed
        peaks = [json.loads(m)["f32_gflops"] for m in lines if json.loads(m).get("bench") == "fma_peak"]
        if peaks != [j["fma_peak_gflops"]]: sys.exit(what + ": fma_peak_gflops " + repr(j["fma_peak_gflops"]) + " != " + repr(peaks))
        for k in ("forward", "forward_backward"):  # each share printed is its rate over the peak
            if k + "_fma_share" in j and abs(j[k + "_fma_share"] - j[k + "_gflops"] / j["fma_peak_gflops"]) > 1e-3 * j[k + "_fma_share"]:
                sys.exit(what + ": " + k + "_fma_share " + repr(j[k + "_fma_share"]))
        if "forward_fma_share" not in j and "forward_backward_fma_share" not in j: sys.exit(what + ": no share of the peak: " + l)
    if j.get("bench") == "nets" and str(j.get("network")).endswith("_fused") and not j["forward_backward_gflops"] > 0:
        sys.exit(what + ": a fused training pass " + l)
    if j.get("bench") == "fixed_order_gemm":  # the networks product: the copy in use is the widest the CPU has
        gemms = [json.loads(m) for m in lines if json.loads(m).get("bench") == "fixed_order_gemm"]
        if [g["in_use"] for g in gemms].count(True) != 1: sys.exit(what + ": not one fixed_order_gemm copy in use")
        if not (j["gflops"] > 0 and abs(j["fma_share"] - j["gflops"] / j["core_fma_peak_gflops"]) < 1e-3 * j["fma_share"]):
            sys.exit(what + ": fixed_order_gemm " + l)
    if j.get("bench") == "train":  # the floor is timed on rows with the alive shares of the run
        for k in ("ll_forward_alive_share", "ll_train_alive_share", "hl_forward_alive_share", "hl_train_alive_share"):
            if not 0.0 <= j.get(k, -1.0) <= 1.0: sys.exit(what + ": " + k + " = " + repr(j.get(k)))
        if j["ll_forward_alive_share"] <= 0.0: sys.exit(what + ": no other aircraft alive in the LL rows")
        # The chunk wait is part of the update it is measured in.
        if not 0.0 <= j.get("ppo_chunk_wait_s", -1.0) <= j["ppo_s"]: sys.exit(what + ": ppo_chunk_wait_s " + repr(j.get("ppo_chunk_wait_s")))
        if not 0.0 <= j.get("es_chunk_wait_s", -1.0) <= j["es_s"]: sys.exit(what + ": es_chunk_wait_s " + repr(j.get("es_chunk_wait_s")))
        # The rate is per update: the wall time of the run without the wait for its last figure
        # (run_end_s: the gnuplot draw at the final checkpoint), which a run pays once at any length.
        end = j.get("run_end_s", -1.0)
        if not 0.0 <= end < j["total_s"]: sys.exit(what + ": run_end_s " + repr(end))
        if shutil.which("gnuplot") and end <= 0.0: sys.exit(what + ": no wait for the last figure with gnuplot installed")
        if j["runs"] == 1:
            want_rate = j["env_steps"] * (j["aircraft"] // j["envs"]) / (j["total_s"] - end)  # env_steps sums the envs
            if abs(j["aircraft_steps_per_s"] / want_rate - 1.0) > 2e-3:
                sys.exit(what + ": aircraft_steps_per_s " + repr(j["aircraft_steps_per_s"]) + " != " + repr(want_rate))
        parts = sum(j[k] for k in ("env_s", "inference_s", "ppo_s", "es_s", "io_s", "other_s", "run_end_s"))
        if abs(parts - j["total_s"]) > 2e-3 * j["total_s"] + 1e-3: sys.exit(what + ": parts " + repr(parts) + " != total_s")
' "$1" "${2:-}" || exit 1
}
out=$("$bin" bench train --config "$weird" --updates 1 --repeat 1 --json --set race.n_env=2 2>&1) || fail "bench train: $out"
check "bench train" "$weird" <<< "$out"
out=$("$bin" bench nets --samples 16 --repeats 1 --json 2>&1) || fail "bench nets: $out"
check "bench nets" <<< "$out"
for n in ll_actor_critic_fused hl_critic_es_d1_d2_fused hl_critic_es_d3_fused; do
  grep -q "\"network\": \"$n\"" <<< "$out" || fail "bench nets: no line for the training pass $n"
done
out=$("$bin" bench sim --aircraft 8 --substeps 10 --repeats 1 --threads 1 --json 2>&1) || fail "bench sim: $out"
check "bench sim" <<< "$out"
echo OK
