// `bench train`'s network floor (mean batches, alive shares, the work priced at two cost
// measurements) and the benchmarks' medians; the simulator and env benches on tiny cases.
#include <gtest/gtest.h>

#include <cmath>

#include "bench/network_floor.hpp"
#include "bench/network_cost.hpp"
#include "bench/sim_throughput.hpp"
#include "bench/timing.hpp"
#include "io/input_error.hpp"
#include "agents/expected_sarsa.hpp"
#include "train/obs_views.hpp"

namespace f16race::bench {
namespace {

TEST(BenchTiming, MedianOfOddAndEvenCounts) {
  EXPECT_DOUBLE_EQ(median_of({3.0, 1.0, 2.0}), 2.0);
  EXPECT_DOUBLE_EQ(median_of({4.0, 1.0, 3.0, 2.0}), 2.5);
  int calls = 0;
  EXPECT_GE(time_median_s([&]() { ++calls; }, 3), 0.0);
  EXPECT_EQ(calls, 4);  // one warm-up, three timed
}

TEST(BenchNetworkFloor, MeanBatchRoundsAndNeverGoesBelowOne) {
  EXPECT_EQ(mean_batch(10, 4), 3);  // 2.5 rounds up
  EXPECT_EQ(mean_batch(9, 4), 2);
  EXPECT_EQ(mean_batch(1, 10), 1);
  EXPECT_EQ(mean_batch(100, 0), 0);  // no calls: no batch
}

TEST(BenchNetworkFloor, AliveShareFallsBackToTheRandomRowsShare) {
  EXPECT_DOUBLE_EQ(alive_share(63, 10, 7), 0.9);
  EXPECT_DOUBLE_EQ(alive_share(0, 0, 7), kDefaultAliveShare);
  EXPECT_DOUBLE_EQ(alive_share(5, 10, 0), kDefaultAliveShare);
}

TEST(BenchNetworkFloor, PricesTheWorkAtTheMeanOfBothCosts) {
  train::TrainConfig cfg;
  train::NetworkWork w;
  w.ll_forward_rows = 1000, w.ll_forward_calls = 10;
  w.ll_train_rows = 400, w.ll_train_calls = 4;
  w.hl_forward_rows = 30, w.hl_forward_calls = 30;
  const FloorCosts before{1e-6, 3e-6, 2e-6, 0.0}, after{3e-6, 5e-6, 2e-6, 1.0};
  const NetworkFloor f = price_floor(cfg, w, before, after);
  EXPECT_DOUBLE_EQ(f.ll_forward_s, 1000 * 2e-6);
  EXPECT_DOUBLE_EQ(f.ll_train_s, 400 * 4e-6);
  EXPECT_DOUBLE_EQ(f.hl_forward_s, 30 * 2e-6);
  EXPECT_DOUBLE_EQ(f.hl_train_s, 0.0);  // no rows: nothing to price
  EXPECT_DOUBLE_EQ(f.total_s, f.ll_forward_s + f.ll_train_s + f.hl_forward_s);
  EXPECT_EQ(f.ll_forward_batch, 100);
  EXPECT_EQ(f.ll_train_batch, 100);
  EXPECT_EQ(f.hl_forward_batch, 1);
  EXPECT_EQ(f.hl_train_batch, 0);
  EXPECT_DOUBLE_EQ(f.ll_forward_alive, 0.0);  // rows without alive aircraft counted
  EXPECT_DOUBLE_EQ(f.hl_train_alive, kDefaultAliveShare);
}

// The physical floor: forward rows at one forward's FLOPs, training rows at three, priced at the peak.
TEST(BenchNetworkFloor, PhysicalFloorCountsTrainingRowsThriceAndPricesAtThePeak) {
  train::TrainConfig cfg;
  train::NetworkWork w;
  w.ll_forward_rows = 1000;
  w.ll_train_rows = 100;
  w.hl_forward_rows = 10;
  w.hl_train_rows = 5;
  const PhysicalFloor f = physical_floor(cfg, w, 200.0);
  models::LlActorCriticConfig lc = cfg.ll.net;
  lc.dims = train::obs_dims(cfg.race);
  agents::EsConfig ec = cfg.hl;
  ec.dims = lc.dims;
  if (ec.n_atoms > 1 && !(ec.v_max > ec.v_min)) ec.v_max = ec.v_min + 1.0;
  const double ll = static_cast<double>(models::LlActorCritic(lc)->flops_per_sample());
  const double hl = static_cast<double>(models::HlCritic(agents::es_critic_config(ec))->flops_per_sample());
  ASSERT_GT(ll, 0.0);
  ASSERT_GT(hl, 0.0);
  EXPECT_DOUBLE_EQ(f.flops, ll * (1000 + 3 * 100) + hl * (10 + 3 * 5));
  EXPECT_DOUBLE_EQ(f.seconds, f.flops / 200e9);
  EXPECT_EQ(physical_floor(cfg, w, 0.0).seconds, 0.0);  // no peak measured: no floor
}

TEST(BenchSimThroughput, LawNamesAndATinyCase) {
  EXPECT_EQ(parse_stage_law("waypoint"), dynamics::StageLaw::kWaypoint);
  EXPECT_THROW(parse_stage_law("pilot"), io::InputError);
  SimBenchCase c;
  c.aircraft = 16;
  c.substeps = 2;
  c.repeats = 1;
  c.law = dynamics::StageLaw::kWaypoint;
  const double rate = sim_substeps_per_s(c);
  EXPECT_TRUE(std::isfinite(rate) && rate > 0.0) << rate;
}

TEST(BenchSimThroughput, EnvAgainstTheBareSimulator) {
  race::RaceConfig cfg;
  cfg.n_env = 2;
  cfg.team_size = 1;
  const EnvRates r = env_steps_per_s(cfg, 1, 2, 1);
  EXPECT_EQ(r.aircraft, 4);
  EXPECT_GT(r.env_steps_per_s, 0.0);
  EXPECT_GT(r.sim_steps_per_s, 0.0);
}

}  // namespace
}  // namespace f16race::bench
