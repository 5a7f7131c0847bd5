// bench train's report: the JSON line parses and carries the medians and every run's figures;
// the text names the median rate, the runs and the breakdown's shares.
#include <gtest/gtest.h>
#include <yaml-cpp/yaml.h>

#include <string>

#include "bench/train_bench_report.hpp"

namespace f16race::bench {
namespace {

TrainBenchResult two_runs() {
  TrainBenchResult res;
  for (int k = 0; k < 2; ++k) {
    TrainBenchRun run;
    run.summary.env_steps = 4096;
    run.summary.time.env = 1.0 + k;
    run.summary.time.ppo = 2.0;
    run.summary.time.total = 4.0 + k;
    run.floor.ll_forward_batch = 256;
    run.rate = 1000.0 * (k + 1);
    run.floor_rate = 4000.0;
    res.runs.push_back(run);
    res.rates.push_back(run.rate);
    res.floor_rates.push_back(run.floor_rate);
    res.ratios.push_back(run.rate / run.floor_rate);
    res.env_s.push_back(run.summary.time.env);
    for (auto* v : {&res.inference_s, &res.ppo_s, &res.es_s, &res.io_s, &res.ppo_chunk_wait_s, &res.run_end_s})
      v->push_back(0.5);
  }
  res.runs[1].physical.flops = 2.0e9;
  res.fma_gflops = 400.0;
  res.physical_floor_rate = 60000.0;
  res.median_run = 1;
  res.rate = 1500.0;
  res.floor_rate = 4000.0;
  res.ratio = 0.375;
  return res;
}

TEST(TrainBenchReport, JsonIsOneParsableLineWithTheMediansAndEveryRun) {
  train::TrainConfig cfg;
  cfg.race.n_env = 32;
  cfg.race.team_size = 4;
  const std::string json = train_bench_json("configs/a \"b\".yaml", cfg, two_runs());
  ASSERT_FALSE(json.empty());
  EXPECT_EQ(json.back(), '\n');
  EXPECT_EQ(json.find('\n'), json.size() - 1) << "one line";
  const YAML::Node j = YAML::Load(json);  // JSON is YAML's flow style
  EXPECT_EQ(j["config"].as<std::string>(), "configs/a \"b\".yaml");
  EXPECT_EQ(j["envs"].as<int>(), 32);
  EXPECT_EQ(j["aircraft"].as<int>(), 256);
  EXPECT_EQ(j["aircraft_steps_per_s"].as<double>(), 1500.0);
  EXPECT_EQ(j["env_s"].as<double>(), 2.0) << "the median run's breakdown";
  EXPECT_EQ(j["ll_forward_batch"].as<int>(), 256);
  EXPECT_EQ(j["runs"].as<int>(), 2);
  EXPECT_EQ(j["runs_aircraft_steps_per_s"][1].as<double>(), 2000.0);
  EXPECT_EQ(j["runs_floor_ratio"][0].as<double>(), 0.25);
  EXPECT_EQ(j["fma_peak_gflops"].as<double>(), 400.0);
  EXPECT_EQ(j["network_gflop"].as<double>(), 2.0) << "the median run's";
  EXPECT_EQ(j["physical_floor_ratio"].as<double>(), 0.025);
}

TEST(TrainBenchReport, TextNamesTheMedianTheRunsAndTheShares) {
  train::TrainConfig cfg;
  const std::string text = train_bench_text("configs/default.yaml", cfg, two_runs());
  EXPECT_NE(text.find("-> 1500 aircraft-steps/s end to end (median of 2: 1000, 2000)"), std::string::npos) << text;
  // The median run: env 2 s and PPO 2 s of a 5 s loop.
  EXPECT_NE(text.find("env (sim + race + obs) 40%, inference 0%, PPO updates 40%"), std::string::npos) << text;
  EXPECT_NE(text.find("network floor 4000 aircraft-steps/s"), std::string::npos) << text;
  EXPECT_NE(text.find("physical floor 60000 aircraft-steps/s: the median run's 2.0 GFLOP of networks at the CPU's "
                      "float FMA peak, 400 GFLOP/s (end to end / physical floor 0.025; the kernel-priced floor above "
                      "is 0.067 of it)"),
            std::string::npos)
      << text;
}

}  // namespace
}  // namespace f16race::bench
