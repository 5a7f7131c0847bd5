#pragma once
// `bench train`'s measurements: end-to-end training throughput (aircraft LL steps per second
// including inference and both learners' updates) against the network floor, in one process or
// as one rank of a group. The command prints them.
#include <cstdint>
#include <string>
#include <vector>

#include "bench/network_floor.hpp"
#include "dist/process_group.hpp"
#include "train/train_config.hpp"
#include "train/trainer.hpp"

namespace f16race::bench {

// One timed training run and its floor.
struct TrainBenchRun {
  train::TrainSummary summary;
  NetworkFloor floor;
  PhysicalFloor physical;
  double rate = 0, floor_rate = 0;  // aircraft-steps/s end to end, and at the floor
  double physical_floor_rate = 0;   // ... and at the physical floor (its FLOPs at the FMA peak)
};

struct TrainBenchResult {
  std::vector<TrainBenchRun> runs;  // the runs that count (the cold first one dropped when there are more)
  // Per run, in `runs`' order: end-to-end and floor rates, their ratio, and the time breakdown.
  std::vector<double> rates, floor_rates, ratios, env_s, inference_s, ppo_s, es_s, io_s, ppo_chunk_wait_s, run_end_s;
  std::size_t median_run = 0;  // by end-to-end rate: the run whose breakdown is reported
  double rate = 0, floor_rate = 0, ratio = 0;  // medians over `runs`
  double fma_gflops = 0;              // the CPU's float FMA peak at these threads (bench/fma_peak.hpp)
  double physical_floor_rate = 0;     // median over `runs`
};

// A run folder of this process under the temporary directory, so two benches at once do not
// meet in one.
std::string scratch_run_dir();

// `repeat` runs of `updates` updates, alternating with the floor's timings: run 1, costs 1, run 2,
// costs 2, ... Run k > 1 is priced at the mean of costs k-1 and k (measured just before and just
// after it) and is warm; run 1 (cold start, one-sided floor) counts only when it is the only one.
TrainBenchResult bench_training(const train::TrainConfig& cfg, long long updates, int repeat);

// The group's identity for `bench train` ranks: the same binary, updates, configs and overrides.
std::string train_bench_fingerprint(long long updates, const std::vector<std::string>& configs,
                                    const std::vector<std::string>& overrides);

// One run of the group; every rank's figures (meaningful as the group's on rank 0).
struct GroupTrainBench {
  std::int64_t env_steps = 0;  // the group's
  double slowest_s = 0;        // the slowest rank's per-update time
  double rate = 0;             // aircraft-steps/s of the group over slowest_s
  std::vector<double> rank_rate, rank_communication_share;  // per rank
};
// On one host the ranks share its cores: this measures the cost of the group, not a speed-up.
GroupTrainBench bench_training_in_group(const train::TrainConfig& cfg, long long updates, dist::Group& group);

}  // namespace f16race::bench
