// The high level's targets fit its critic: for every shipped config at both HL horizons, the
// derived reward scale and C51 support hold the discounted HL return of real races (scripted
// pilots on the config's own tracks), measured here rather than assumed.
#include <gtest/gtest.h>
#include <yaml-cpp/yaml.h>

#include <algorithm>
#include <cmath>
#include <string>
#include <vector>

#include "io/yaml_config.hpp"
#include "race/race_env.hpp"
#include "race/scripted_pilot.hpp"
#include "train/train_config.hpp"

namespace f16race::train {
namespace {

TrainConfig shipped(const std::string& name, double dt_hl_s) {
  const std::string path = std::string(F16RACE_CONFIG_DIR) + "/" + name;
  YAML::Node root = io::load_yaml_file(path);
  io::apply_override(root, "race.dt_hl_s=" + std::to_string(dt_hl_s));
  io::apply_override(root, "race.n_env=6");
  return read_train_config(root, path);
}

// Scaled, discounted HL returns G_k = sum_{m >= k} gamma^(m-k) R_m from every decision k of
// every learner-side aircraft over one race per env; R_m = reward_scale x the interval's summed
// HL reward (the trainer's accumulation).
std::vector<double> race_returns(const TrainConfig& cfg) {
  race::RaceEnv env(cfg.race);
  const int n = env.n_aircraft();
  std::vector<float> a(static_cast<std::size_t>(n) * race::kActionDim);
  std::vector<std::int64_t> bins(static_cast<std::size_t>(n) * race::kHlDims, cfg.race.hl_center_bin());
  std::vector<std::vector<double>> intervals(n);  // per aircraft, R_m of this race
  std::vector<double> open(n, 0.0);
  std::vector<int> finished(cfg.race.n_env, 0);
  std::vector<double> out;
  const int max_steps = static_cast<int>(cfg.race.time_limit_s / cfg.race.dt_ll_s) + 10;
  for (int s = 0; s < max_steps; ++s) {
    const bool any_due = std::any_of(env.hl_due(), env.hl_due() + cfg.race.n_env, [](auto d) { return d != 0; });
    if (any_due) {
      for (int i = 0; i < n; ++i) {
        const int e = i / env.n_agent();
        if (!env.hl_due()[e] || finished[e] || s == 0) continue;
        intervals[i].push_back(open[i]);
        open[i] = 0.0;
      }
      env.set_hl_actions(bins.data());
    }
    race::scripted_actions(env, race::ScriptedPilotConfig{}, a.data());
    env.step(a.data());
    for (int i = 0; i < n; ++i) {
      const int e = i / env.n_agent();
      if (finished[e]) continue;
      open[i] += cfg.hl.reward_scale * env.hl_reward()[i];
      if (!env.env_done()[e]) continue;
      intervals[i].push_back(open[i]);
      double g = 0.0;
      for (auto it = intervals[i].rbegin(); it != intervals[i].rend(); ++it) {
        g = *it + cfg.hl.gamma * g;
        out.push_back(g);
      }
    }
    for (int e = 0; e < cfg.race.n_env; ++e) finished[e] = finished[e] || env.env_done()[e];
    if (std::all_of(finished.begin(), finished.end(), [](int f) { return f != 0; })) break;
  }
  return out;
}

TEST(HlTargets, DerivedScaleAndSupportHoldEveryRaceReturnOfEveryShippedConfig) {
  for (const char* name : {"default.yaml", "paper.yaml", "smoke.yaml", "long.yaml"}) {
    for (const double dt_hl : {8.0, 20.0}) {
      const TrainConfig cfg = shipped(name, dt_hl);
      SCOPED_TRACE(std::string(name) + " dt_hl_s " + std::to_string(dt_hl));
      EXPECT_DOUBLE_EQ(cfg.hl.reward_scale, cfg.race.dt_ll_s / cfg.race.dt_hl_s);
      EXPECT_DOUBLE_EQ(cfg.hl.v_min, -cfg.hl.v_max);
      EXPECT_GE(cfg.hl.v_max, hl_return_bound(cfg));
      EXPECT_LT(cfg.hl.v_max, hl_return_bound(cfg) * 1.01);
      // The bound itself: 1.1 per interval, at most ceil(time_limit / dt_hl) discounted intervals.
      const double decisions = std::ceil(cfg.race.time_limit_s / dt_hl - 1e-9);
      EXPECT_NEAR(hl_return_bound(cfg), 1.1 * (1.0 - std::pow(cfg.hl.gamma, decisions)) / (1.0 - cfg.hl.gamma), 1e-9);
      const std::vector<double> g = race_returns(cfg);
      ASSERT_GT(g.size(), 20u);
      double lo = 0.0, hi = 0.0;
      for (double x : g) lo = std::min(lo, x), hi = std::max(hi, x);
      EXPECT_GE(lo, cfg.hl.v_min);
      EXPECT_LE(hi, cfg.hl.v_max);
      // ...and is not so wide that the atoms are wasted: the races use a good part of it.
      EXPECT_GT(std::max(-lo, hi), 0.3 * cfg.hl.v_max);
    }
  }
}

TEST(HlTargets, ExplicitSupportAndScaleAreKept) {
  YAML::Node root = YAML::Load("hl: {v_min: -50, v_max: 60, reward_scale: 1.0}");
  const TrainConfig cfg = read_train_config(root, "cfg.yaml");
  EXPECT_EQ(cfg.hl.v_min, -50.0);
  EXPECT_EQ(cfg.hl.v_max, 60.0);
  EXPECT_EQ(cfg.hl.reward_scale, 1.0);
  // Resolved configs carry the derived numbers, so a run folder shows the support it used.
  const TrainConfig d = read_train_config(YAML::Load("race: {dt_hl_s: 20}"), "cfg.yaml");
  const YAML::Node y = YAML::Load(train_config_yaml(d));
  EXPECT_DOUBLE_EQ(y["hl"]["reward_scale"].as<double>(), 0.08 / 20.0);
  EXPECT_DOUBLE_EQ(y["hl"]["v_max"].as<double>(), d.hl.v_max);
  EXPECT_GT(d.hl.v_max, 3.0);  // 120 s race: 6 decisions
}

}  // namespace
}  // namespace f16race::train
