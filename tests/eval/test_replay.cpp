// Replays: a trained run against each kind of opponent, recorded to the end, files written;
// missing runs refused by name.
#include <gtest/gtest.h>
#include <yaml-cpp/yaml.h>

#include <algorithm>
#include <cmath>
#include <filesystem>
#include <string>
#include <vector>

#include "eval/replay.hpp"
#include "io/yaml_config.hpp"
#include "train/trainer.hpp"

namespace f16race::eval {
namespace {

namespace fs = std::filesystem;

// Each test its own folder: ctest runs tests in parallel.
std::string tiny_run(const std::string& name, const std::vector<std::string>& overrides = {}) {
  const fs::path dir = fs::temp_directory_path() / ("f16race_replay_" + name);
  fs::remove_all(dir);
  YAML::Node root = YAML::Load(R"(
config_version: 1  # the tiny runs these tests were written for: version 1's defaults
race: {n_env: 2, team_size: 2, time_limit_s: 12.0, dt_hl_s: 1.6, track: {n_waypoints: 5}}
ll: {n_steps: 8, n_minibatches: 2, n_epochs: 1, hidden: [8, 8], d_model: 8, n_heads: 2}
hl: {hidden: [8, 8], d_model: 8, n_heads: 2, n_atoms: 11, n_steps_per_update: 1}
train: {total_env_steps: 100, ll_phase_updates: 1, hl_phase_updates: 1}
)");
  for (const std::string& kv : overrides) io::apply_override(root, kv);
  train::Trainer t(train::read_train_config(root, "test"), dir.string());
  t.run(nullptr, 2);
  return dir.string();
}

TEST(Replay, RacesEveryOpponentKindToTheEnd) {
  const std::string run = tiny_run("run");
  for (const std::string opp : {"self", "untrained", "scripted"}) {
    ReplayOptions o;
    o.run = run;
    o.opponent = opp;
    o.seed = 5;
    const RaceReplay r = run_replay(o);
    const race::RaceTrace& t = r.trace;
    EXPECT_TRUE(t.done) << opp;
    // The race lasts until the step after the last aircraft's last recorded row.
    double last_row_end_s = 0.0;
    for (const auto& rows : t.rows)
      if (!rows.empty()) last_row_end_s = std::max(last_row_end_s, rows.back().t_s + r.race.dt_ll_s);
    EXPECT_NEAR(t.duration_s, last_row_end_s, 1e-9) << opp;
    EXPECT_EQ(r.blue, "f16race_replay_run");  // the run folder's name
    EXPECT_EQ(r.red, opp == "self" ? r.blue : opp);
    ASSERT_EQ(t.rows.size(), 4u);
    // The learned sides take HL decisions every dt_hl_s; the scripted side takes none.
    EXPECT_FALSE(t.goals[0].empty());
    EXPECT_EQ(t.goals[2].empty(), opp == "scripted") << opp;
    const std::string dir = (fs::temp_directory_path() / ("f16race_replay_out_" + opp)).string();
    fs::remove_all(dir);
    std::string msg;
    write_replay(r, dir, &msg);
    for (const char* f : {"replay.md", "replay_agent0.csv", "replay_goals.csv", "replay.acmi", "replay.gp"})
      EXPECT_TRUE(fs::exists(fs::path(dir) / f)) << f;
  }
  // Same seed, same race.
  ReplayOptions o;
  o.run = run;
  o.seed = 5;
  const RaceReplay a = run_replay(o), b = run_replay(o);
  ASSERT_EQ(a.trace.rows[1].size(), b.trace.rows[1].size());
  EXPECT_EQ(a.trace.rows[1].back().pn_ft, b.trace.rows[1].back().pn_ft);
}

// "autopilot@line": the autopilot flies its start lanes shifted onto the race's racing line, so
// its aircraft fly otherwise than on their lanes from the first bend; a run trained on the
// center-line has no line to give it and is refused in one line.
TEST(Replay, TheAutopilotOnTheRacingLineFliesOtherTrajectories) {
  const std::string run = tiny_run("line_run", {"race.goal_line_frac=0.25"});
  ReplayOptions o;
  o.run = run;
  o.seed = 5;
  o.opponent = "autopilot";
  const RaceReplay lanes = run_replay(o);
  o.opponent = "autopilot@line";
  const RaceReplay line = run_replay(o);
  EXPECT_EQ(line.red, "autopilot@line");
  ASSERT_FALSE(line.line.right_ft.empty());
  double apart = 0.0;  // how far red's first aircraft flies from where it flew on its lane
  const auto& a = lanes.trace.rows[2];
  const auto& b = line.trace.rows[2];
  for (std::size_t k = 0; k < std::min(a.size(), b.size()); ++k)
    apart = std::max(apart, std::hypot(a[k].pn_ft - b[k].pn_ft, a[k].pe_ft - b[k].pe_ft));
  EXPECT_GT(apart, 50.0);
  EXPECT_EQ(lanes.trace.rows[0].front().pn_ft, line.trace.rows[0].front().pn_ft);  // the same race
  o.run = tiny_run("center_run");
  try {
    run_replay(o);
    ADD_FAILURE() << "a center-line run gave the autopilot a line";
  } catch (const io::InputError& e) {
    EXPECT_NE(std::string(e.what()).find("trained on the center-line (race.goal_line_frac 0)"), std::string::npos)
        << e.what();
  }
}

TEST(Replay, BlocksAgreeWithTheRecordedTrajectories) {
  // Every block of a replay, checked against the trajectories the recorder wrote: opponents, the
  // blocker ahead by at most 1000 ft and within 300 ft in the cross-section where the window
  // opened, the outcome within 5 s. Several tracks, so that some blocks happen.
  const std::string run = tiny_run("blocks");
  int n_blocks = 0;
  for (std::uint64_t seed = 1; seed <= 12; ++seed) {
    ReplayOptions o;
    o.run = run;
    o.opponent = "scripted";
    o.seed = seed;
    const RaceReplay r = run_replay(o);
    const race::RaceTrace& t = r.trace;
    const auto row_at = [&](int a, double t_s) {
      const race::TraceRow* best = &t.rows[a].front();
      for (const race::TraceRow& x : t.rows[a])
        if (std::fabs(x.t_s - t_s) < std::fabs(best->t_s - t_s)) best = &x;
      return *best;
    };
    for (const race::BlockEvent& b : r.blocks) {
      ++n_blocks;
      EXPECT_NE(race::RaceEnv::team_of(b.blocker, t.team_size), race::RaceEnv::team_of(b.blocked, t.team_size));
      const race::TraceRow rb = row_at(b.blocker, b.t_open_s), ro = row_at(b.blocked, b.t_open_s);
      EXPECT_NEAR(rb.t_s, b.t_open_s, 1e-9);
      const double lead = rb.s_ft - ro.s_ft;
      EXPECT_GT(lead, 0.0);
      EXPECT_LE(lead, race::kBlockAheadFt + 1e-6);
      EXPECT_LE(std::hypot(rb.lateral_ft - ro.lateral_ft, rb.vertical_ft - ro.vertical_ft), race::kBlockRadiusFt + 1e-6);
      EXPECT_GT(b.t_s, b.t_open_s);
      EXPECT_LE(b.t_s - b.t_open_s, race::kBlockWindowS + 1e-6);
      if (b.taken_out) {
        EXPECT_NEAR(t.out_s[b.blocked], b.t_s, 1e-6);
      }
    }
  }
  EXPECT_GT(n_blocks, 0);  // else the checks above checked nothing
}

TEST(Replay, FixedHighLevelControls) {
  const std::string run = tiny_run("ctl");
  ReplayOptions o;
  o.run = run + "@center";
  o.opponent = run + "@random";
  o.seed = 4;
  const RaceReplay r = run_replay(o);
  EXPECT_EQ(r.blue, "f16race_replay_ctl@center");
  EXPECT_EQ(r.red, "f16race_replay_ctl@random");
  ASSERT_EQ(r.trace.goals.size(), 4u);
  // Blue's goals are the middle bin: on the center-line, the two kept apart across it. Red's random bins leave it.
  double red_off = 0.0;
  for (int a = 0; a < 4; ++a) {
    ASSERT_FALSE(r.trace.goals[a].empty()) << a;
    for (const race::GoalMark& g : r.trace.goals[a]) {
      if (a < 2) {  // at most half the teammates' goal separation from it, either side
        EXPECT_LE(std::hypot(g.lateral_ft, g.vertical_ft), 0.5 * race::RaceConfig{}.goal_min_separation_ft + 1.0) << a;
      } else {
        red_off = std::max(red_off, std::hypot(g.lateral_ft, g.vertical_ft));
      }
    }
  }
  EXPECT_GT(red_off, 10.0);
  // Deterministic for a seed.
  const RaceReplay again = run_replay(o);
  ASSERT_EQ(again.trace.goals[2].size(), r.trace.goals[2].size());
  EXPECT_EQ(again.trace.goals[2].back().lateral_ft, r.trace.goals[2].back().lateral_ft);
  o.opponent = "scripted@center";
  EXPECT_THROW(run_replay(o), std::runtime_error);
}

// RUN@center_y flies the run's own high level with the lateral goal axis on the middle bin: its
// goals sit on the center-line laterally, and at the race's first decision (the same state as
// the run's own replay) the other axes are the run's own choice.
TEST(Replay, OneAxisRuleKeepsThePolicyOnTheOtherAxes) {
  const std::string run = tiny_run("axis");
  ReplayOptions o;
  o.run = run;
  o.opponent = run;
  o.seed = 5;
  const RaceReplay own = run_replay(o);
  o.run = run + "@center_y";
  const RaceReplay fixed = run_replay(o);
  EXPECT_EQ(fixed.blue, "f16race_replay_axis@center_y");
  bool own_off_middle = false;
  for (int a = 0; a < 2; ++a) {
    ASSERT_FALSE(fixed.trace.goals[a].empty()) << a;
    for (const race::GoalMark& g : fixed.trace.goals[a]) EXPECT_EQ(g.bins[1], 3) << a;
    for (const race::GoalMark& g : own.trace.goals[a]) own_off_middle = own_off_middle || g.bins[1] != 3;
    const race::GoalMark &f0 = fixed.trace.goals[a].front(), &o0 = own.trace.goals[a].front();
    EXPECT_EQ(f0.t_s, o0.t_s);
    EXPECT_EQ(f0.bins[0], o0.bins[0]) << a;
    EXPECT_EQ(f0.bins[2], o0.bins[2]) << a;
  }
  EXPECT_TRUE(own_off_middle);  // the run's own high level does choose other lateral bins
  // Red (the run itself) decides its first goals from the same state in both replays.
  for (int a = 2; a < 4; ++a)
    for (int k = 0; k < 3; ++k) EXPECT_EQ(fixed.trace.goals[a].front().bins[k], own.trace.goals[a].front().bins[k]);
}

TEST(Replay, RefusesMissingRuns) {
  ReplayOptions o;
  o.run = "/nonexistent/run";
  try {
    run_replay(o);
    FAIL();
  } catch (const std::runtime_error& e) {
    EXPECT_NE(std::string(e.what()).find("/nonexistent/run: not a training run"), std::string::npos) << e.what();
  }
  o.run = tiny_run("refuse");
  o.opponent = "/nonexistent/other";
  EXPECT_THROW(run_replay(o), std::runtime_error);
}

}  // namespace
}  // namespace f16race::eval
