// Race recording: every race ends once, trajectories are in time order and stop when an
// aircraft is out, goals land where the env placed them, and the writers produce the files.
#include <gtest/gtest.h>

#include <filesystem>
#include <fstream>
#include <string>
#include <vector>

#include "dynamics/engine.hpp"
#include "race/race_env.hpp"
#include "race/race_recorder.hpp"
#include "support/center_line_race.hpp"
#include "race/scripted_pilot.hpp"

namespace f16race::race {
namespace {

namespace fs = std::filesystem;

TEST(RaceRecorder, RecordsEachRaceToItsEndWithGoals) {
  RaceConfig c = test_support::center_line_race();
  c.n_env = 3;
  c.team_size = 2;
  c.seed = 11;
  c.time_limit_s = 30.0;
  c.goal_min_separation_ft = 0.0;  // middle bins stay the center-line point (no de-confliction)
  RaceEnv env(c);
  RaceRecorder rec(env);
  std::vector<float> actions(static_cast<std::size_t>(env.n_aircraft()) * kActionDim);
  std::vector<std::int64_t> bins(static_cast<std::size_t>(env.n_aircraft()) * kHlDims, c.hl_bins / 2);
  ScriptedPilotConfig pilot;
  std::vector<float> throttle_action_0;  // env 0, agent 0: the throttle action of each step
  int steps = 0;
  while (rec.remaining() > 0 && steps < 10000) {
    const std::vector<std::uint8_t> due(env.hl_due(), env.hl_due() + c.n_env);
    env.set_hl_actions(bins.data());
    rec.record_goals(env, due.data());
    scripted_actions(env, pilot, actions.data());
    throttle_action_0.push_back(actions[0]);
    rec.before_step(env);
    env.step(actions.data());
    rec.after_step(env);
    ++steps;
  }
  ASSERT_EQ(rec.remaining(), 0);
  for (int e = 0; e < c.n_env; ++e) {
    const RaceTrace& t = rec.trace(e);
    EXPECT_TRUE(t.done);
    EXPECT_NE(t.end, RaceEnv::kEndNone);
    EXPECT_GT(t.duration_s, 0.0);
    EXPECT_LE(t.duration_s, c.time_limit_s + c.dt_ll_s);
    for (int a = 0; a < env.n_agent(); ++a) {
      const auto& rows = t.rows[a];
      ASSERT_FALSE(rows.empty());
      for (std::size_t k = 1; k < rows.size(); ++k) EXPECT_NEAR(rows[k].t_s - rows[k - 1].t_s, c.dt_ll_s, 1e-9);
      if (t.cause[a] != kCauseNone) {
        EXPECT_NEAR(t.out_s[a], rows.back().t_s + c.dt_ll_s, 1e-9);
      }
      // Middle bins: the goal is the center-line point goal_ahead_ft ahead of the aircraft.
      ASSERT_FALSE(t.goals[a].empty());
      const GoalMark& g = t.goals[a].front();
      EXPECT_NEAR(g.lateral_ft, 0.0, 1.0);
      EXPECT_NEAR(g.vertical_ft, 0.0, 1.0);
      EXPECT_NEAR(g.s_ft, rows.front().s_ft + c.goal_ahead(), 5.0);
      for (int k = 0; k < kHlDims; ++k) EXPECT_EQ(g.bins[k], c.hl_center_bin()) << k;
    }
  }
  // Row k + 1 follows step k: its commanded throttle is that step's action, and the governor only
  // takes throttle away, all of it passed through while the step starts below mach_max - 0.05.
  const auto& rows = rec.trace(0).rows[0];
  int passed = 0;
  for (std::size_t k = 0; k + 1 < rows.size(); ++k) {
    const TraceRow& r = rows[k + 1];
    const double cmd = 0.5 * (std::min(std::max(throttle_action_0[k], -1.0f), 1.0f) + 1.0);
    EXPECT_NEAR(r.throttle_cmd, cmd, 1e-7) << k;
    EXPECT_LE(r.throttle, r.throttle_cmd + 1e-12) << k;
    EXPECT_GE(r.throttle, 0.0) << k;
    EXPECT_GE(r.power_pct, 0.0) << k;
    EXPECT_LE(r.power_pct, 100.0) << k;
    if (dynamics::air_data(rows[k].vt_ftps, rows[k].alt_ft).mach < c.mach_max - 0.05) {
      EXPECT_NEAR(r.throttle, r.throttle_cmd, 1e-12) << k;
      ++passed;
    }
  }
  EXPECT_GT(passed, 0);
  const std::string dir = (fs::temp_directory_path() / "f16race_recorder").string();
  fs::remove_all(dir);
  fs::create_directories(dir);
  write_trace_csv(rec.trace(0), dir, "r");
  write_trace_acmi(rec.trace(0), dir + "/r.acmi", "test");
  for (const char* f : {"r_agent0.csv", "r_agent3.csv", "r_goals.csv", "r_track.csv", "r_tube.csv", "r.acmi"})
    EXPECT_TRUE(fs::exists(fs::path(dir) / f)) << f;
  std::ifstream csv(dir + "/r_agent0.csv");
  std::string header;
  std::getline(csv, header);
  EXPECT_NE(header.find(",radius_ft,throttle_cmd,throttle,power_pct,alpha_rad"), std::string::npos) << header;
  // The goals carry the middle bin, so their readers need not know the run's race.hl_bins.
  std::ifstream goals(dir + "/r_goals.csv");
  std::string goal_header, goal_row;
  std::getline(goals, goal_header);
  std::getline(goals, goal_row);
  EXPECT_NE(goal_header.find(",bin_x,bin_y,bin_z,middle_bin"), std::string::npos) << goal_header;
  EXPECT_EQ(goal_row.substr(goal_row.rfind(',') + 1), std::to_string(rec.trace(0).middle_bin)) << goal_row;
  EXPECT_EQ(rec.trace(0).middle_bin, c.hl_center_bin());
  std::ifstream acmi(dir + "/r.acmi");
  const std::string text((std::istreambuf_iterator<char>(acmi)), {});
  int aircraft = 0;
  for (std::size_t p = text.find("Type=Air+FixedWing"); p != std::string::npos; p = text.find("Type=Air+FixedWing", p + 1))
    ++aircraft;
  EXPECT_EQ(aircraft, env.n_agent());
  EXPECT_NE(text.find("Coalition=Red"), std::string::npos);
}

// Full throttle in level flight runs into the Mach governor (as in
// RaceEnv.MachGovernorHoldsFullThrottleInsideTheEnvelope): the rows then record the command
// untouched and the throttle flown cut to the governor's limit, none of it once past the band.
TEST(RaceRecorder, RecordsTheThrottleTheGovernorCuts) {
  RaceConfig c = test_support::center_line_race();
  c.n_env = 1;
  c.team_size = 1;
  c.seed = 42;
  c.tube_grace_s = 1e6;
  c.turn_rate_max_dps = 1e3;
  c.time_limit_s = 1e3;
  RaceEnv env(c);
  RaceRecorder rec(env);
  std::vector<float> a(2 * kActionDim, 0.0f);
  for (int i = 0; i < 2; ++i) {
    a[i * 3 + 0] = 1.0f;  // full throttle, the trim's Nz (level flight), no roll
    a[i * 3 + 1] = static_cast<float>(2.0 * (env.sim().ref(dynamics::kNzRef)[i] - c.nz_ref_min_g) /
                                          (c.nz_ref_max_g - c.nz_ref_min_g) - 1.0);
  }
  for (int k = 0; k < 500 && rec.remaining() > 0; ++k) {
    rec.before_step(env);
    env.step(a.data());
    rec.after_step(env);
  }
  const auto& rows = rec.trace(0).rows[0];
  ASSERT_GT(rows.size(), 400u);
  int cut = 0;
  for (std::size_t k = 1; k < rows.size(); ++k) {
    EXPECT_EQ(rows[k].throttle_cmd, 1.0) << k;
    const double mach = dynamics::air_data(rows[k - 1].vt_ftps, rows[k - 1].alt_ft).mach;  // where step k-1 began
    if (mach < c.mach_max - 0.05) {
      EXPECT_EQ(rows[k].throttle, 1.0) << k;
    }
    if (mach >= c.mach_max - 0.01) {
      EXPECT_NEAR(rows[k].throttle, 0.0, 1e-12) << k;
    }
    cut += rows[k].throttle < 0.999;
  }
  EXPECT_GT(cut, 100) << "most of 40 s at full throttle is spent in the governor's band";
}

}  // namespace
}  // namespace f16race::race
