// Which policy flies which aircraft: rows per policy in aircraft order, each aircraft's position
// in its owner's rows, the scatter of per-policy outputs back into the env's flat arrays, and
// the low-level act of evaluation (network mean, or the goal-following autopilot).
#include <gtest/gtest.h>

#include <stdexcept>
#include <vector>

#include "race/scripted_pilot.hpp"
#include "train/obs_views.hpp"
#include "train/policy_rows.hpp"
#include "train/run_policy.hpp"

namespace f16race::train {
namespace {

std::vector<std::int64_t> as_vector(const torch::Tensor& t) {
  return std::vector<std::int64_t>(t.data_ptr<std::int64_t>(), t.data_ptr<std::int64_t>() + t.numel());
}

TEST(PolicyRows, RowsPositionsAndOwnership) {
  PolicyRows r(3, 7);
  r.assign({0, 1, -1, 0, 2, 1, 0});
  EXPECT_EQ(as_vector(r.rows(0)), (std::vector<std::int64_t>{0, 3, 6}));
  EXPECT_EQ(as_vector(r.rows(1)), (std::vector<std::int64_t>{1, 5}));
  EXPECT_EQ(as_vector(r.rows(2)), (std::vector<std::int64_t>{4}));
  EXPECT_EQ(r.position(6), 2);
  EXPECT_EQ(r.position(5), 1);
  EXPECT_EQ(r.position(2), -1);
  EXPECT_FALSE(r.owns_all(0));
  r.assign(std::vector<int>(7, 1));
  EXPECT_TRUE(r.owns_all(1));
  EXPECT_EQ(r.rows(0).numel(), 0);
  EXPECT_EQ(r.position(4), 4);
  EXPECT_THROW(r.assign({0, 1}), std::logic_error);
  EXPECT_THROW(r.assign({0, 1, 3, 0, 0, 0, 0}), std::logic_error);
}

TEST(PolicyRows, ScatterWritesEachPolicysRowsAndNothingElse) {
  PolicyRows r(2, 4);
  r.assign({1, 0, 1, -1});
  std::vector<float> actions(4 * 3, -9.0f);
  scatter_rows(r.rows(0), torch::tensor({{1.0f, 2.0f, 3.0f}}), actions.data());
  // A transposed (non-contiguous) output is read row by row like a contiguous one.
  scatter_rows(r.rows(1), torch::tensor({{4.0f, 7.0f}, {5.0f, 8.0f}, {6.0f, 9.0f}}).t(), actions.data());
  EXPECT_EQ(actions, (std::vector<float>{4, 5, 6, 1, 2, 3, 7, 8, 9, -9, -9, -9}));
  std::vector<std::int64_t> bins(4 * 3, 3);
  scatter_rows(r.rows(1), torch::tensor({{0, 1, 2}, {6, 5, 4}}, torch::kInt64), bins.data());
  EXPECT_EQ(bins, (std::vector<std::int64_t>{0, 1, 2, 3, 3, 3, 6, 5, 4, 3, 3, 3}));
}

// A run's greedy low level in tournaments and replays: the network's mean on its rows, or, for
// a run trained with train.ll_pilot autopilot, the autopilot flying each aircraft's goal lane;
// rows not given keep what they held.
TEST(GreedyLowLevel, NetworkMeanOrGoalFollowingAutopilotOnTheGivenRowsOnly) {
  TrainConfig c;
  c.loop.ll_throttle = LowLevelThrottle::kPolicy;  // the network's own throttle
  c.race.n_env = 2;
  c.race.team_size = 2;
  c.race.seed = 5;
  resolve_hl_scales(&c);
  race::RaceEnv env(c.race);
  std::vector<std::int64_t> bins(static_cast<std::size_t>(env.n_aircraft()) * race::kHlDims, 1);
  env.set_hl_actions(bins.data());
  const torch::Tensor rows = torch::tensor(std::vector<std::int64_t>{1, 2, 6});
  at::Generator gen = models::make_generator(3);
  const models::LlObs obs = ll_obs_view(env);
  const std::size_t n = static_cast<std::size_t>(env.n_aircraft()) * race::kActionDim;
  for (int autopilot = 0; autopilot < 2; ++autopilot) {
    TrainConfig ci = c;
    ci.loop.ll_pilot = autopilot ? LowLevelPilot::kAutopilot : LowLevelPilot::kPpo;
    const RunPolicy p = untrained_policy(ci, 7);
    std::vector<float> got(n, 42.0f), want(n, 42.0f);
    greedy_ll_actions(p, env, obs, rows, gen, got.data());
    if (autopilot) {
      race::AutopilotPilotConfig k;
      k.follow_goal = true;
      k.airspeed_ftps = c.race.autopilot_airspeed();  // loop.autopilot_airspeed_ftps 0: the race's set point
      race::autopilot_actions(env, k, want.data(), rows.data_ptr<std::int64_t>(), rows.numel());
    } else {
      scatter_rows(rows, p.ll->act(models::index_rows(obs, rows), gen, false).mean, want.data());
    }
    EXPECT_EQ(got, want) << (autopilot ? "autopilot" : "network");
    int untouched = 0;
    for (float v : got) untouched += v == 42.0f;
    EXPECT_EQ(untouched, static_cast<int>(n) - 3 * race::kActionDim);
  }
  // train.ll_throttle governor: the network's Nz and roll on those rows, the throttle full.
  TrainConfig cg = c;
  cg.loop.ll_throttle = LowLevelThrottle::kGovernor;
  const RunPolicy p = untrained_policy(cg, 7);
  std::vector<float> got(n, 42.0f), want(n, 42.0f);
  greedy_ll_actions(p, env, obs, rows, gen, got.data());
  scatter_rows(rows, p.ll->act(models::index_rows(obs, rows), gen, false).mean, want.data());
  for (std::int64_t r : {1, 2, 6}) {
    EXPECT_NE(want[r * race::kActionDim], 1.0f);
    want[r * race::kActionDim] = 1.0f;
  }
  EXPECT_EQ(got, want);
}

// apply_ll_throttle: every given row's throttle (or rows 0 .. n-1 without an index) full under
// train.ll_throttle governor, nothing else touched; the policy's throttle untouched.
TEST(GreedyLowLevel, GovernorThrottleSetsOnlyTheThrottleOfTheGivenRows) {
  TrainConfig c;
  c.loop.ll_throttle = LowLevelThrottle::kPolicy;
  std::vector<float> a(4 * race::kActionDim, -0.5f);
  const std::int64_t rows[] = {1, 3};
  apply_ll_throttle(c, rows, 2, a.data());
  EXPECT_EQ(a, std::vector<float>(4 * race::kActionDim, -0.5f));
  c.loop.ll_throttle = LowLevelThrottle::kGovernor;
  apply_ll_throttle(c, rows, 2, a.data());
  EXPECT_EQ(a, (std::vector<float>{-0.5f, -0.5f, -0.5f, 1, -0.5f, -0.5f, -0.5f, -0.5f, -0.5f, 1, -0.5f, -0.5f}));
  apply_ll_throttle(c, nullptr, 1, a.data());
  EXPECT_EQ(a[0], 1.0f);
  EXPECT_EQ(a[6], -0.5f);
}

}  // namespace
}  // namespace f16race::train
