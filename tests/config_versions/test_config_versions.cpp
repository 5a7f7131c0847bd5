// config_versions::migrate: the one place that reads configs of older versions.
#include "config_versions/config_versions.hpp"

#include <gtest/gtest.h>

#include <string>

#include "io/yaml_config.hpp"

namespace f16race::config_versions {
namespace {

std::string error_of(const std::string& yaml, Written who = Written::kByUser) {
  try {
    migrate(YAML::Load(yaml), "cfg.yaml", who);
  } catch (const io::ConfigError& e) {
    return e.what();
  }
  return "";
}

std::string emitted(const YAML::Node& n) {
  YAML::Emitter out;
  out << n;
  return out.c_str();
}

// A run folder's config.yaml without config_version was written at version 1: a key it does not
// list had that version's default, which the migration writes in; a listed key is kept.
TEST(ConfigVersions, VersionOneRunFilesGetTheDefaultsOfTheirTime) {
  YAML::Node run = YAML::Load("seed: 2\nrace: {n_env: 8, track: {leg_min_ft: 5000}}\nhl: {agent: es}\n");
  migrate(run, "run/config.yaml", Written::kByTrain);
  EXPECT_EQ(run["race"]["n_env"].as<int>(), 8);
  EXPECT_EQ(run["race"]["time_limit_s"].as<double>(), 120.0);
  EXPECT_EQ(run["race"]["track"]["n_waypoints"].as<int>(), 12);
  EXPECT_EQ(run["race"]["track"]["leg_min_ft"].as<double>(), 5000.0);
  EXPECT_EQ(run["race"]["goal_line_frac"].as<double>(), 0.0);
  EXPECT_EQ(run["race"]["goal_shift_up_frac"].as<double>(), 0.0);
  EXPECT_EQ(run["race"]["autopilot_shift_up_frac"].as<double>(), 0.0);
  EXPECT_EQ(run["ll"]["init_log_std"].as<double>(), 0.0);
  EXPECT_EQ(run["hl"]["agent"].as<std::string>(), "es");
  EXPECT_EQ(run["hl"]["n_steps_per_update"].as<int>(), 10);
  EXPECT_EQ(run["hl"]["minibatch_chunks"].as<int>(), 1);
  EXPECT_EQ(run["train"]["total_env_steps"].as<long long>(), 200000);
  EXPECT_EQ(run["train"]["ll_throttle"].as<std::string>(), "policy");
  EXPECT_EQ(run["train"]["hl_tail_share"].as<double>(), 0.0);
  EXPECT_EQ(run["train"]["hl_tail_members"].as<int>(), 1);
  EXPECT_EQ(run["pool"]["p_center_tail"].as<double>(), 0.0);
}

// A user's config is an overlay on today's defaults: nothing is written in. Version 2 files of
// either writer are taken as they are; the version key itself is consumed.
TEST(ConfigVersions, UserConfigsAndVersionTwoFilesAreLeftAsGiven) {
  for (const auto& [yaml, who] : {std::pair<std::string, Written>{"seed: 1\n", Written::kByUser},
                                  {"config_version: 2\nseed: 1\n", Written::kByTrain},
                                  {"config_version: 2\nseed: 1\n", Written::kByUser}}) {
    YAML::Node n = YAML::Load(yaml);
    migrate(n, "cfg.yaml", who);
    EXPECT_EQ(emitted(n), "seed: 1") << yaml;
  }
  // A user may say their file is of version 1: it then means what it meant then.
  YAML::Node old = YAML::Load("config_version: 1\nseed: 1\n");
  migrate(old, "cfg.yaml", Written::kByUser);
  EXPECT_EQ(old["race"]["time_limit_s"].as<double>(), 120.0);
  EXPECT_FALSE(old["config_version"]);
}

TEST(ConfigVersions, AnUnknownVersionIsRefusedInOneLine) {
  EXPECT_EQ(error_of("config_version: 3\n"),
            "cfg.yaml: config_version: 3 is not a config version this build reads (1 to 2); a newer f16race wrote "
            "it, or leave the key out");
  EXPECT_NE(error_of("config_version: two\n").find("config_version: two is not a config version"), std::string::npos);
  EXPECT_NE(error_of("config_version: 0\n").find("(1 to 2)"), std::string::npos);
}

// Removed switches, as the config.yaml of an older run lists them: at the value this build
// behaves as they are dropped; at another value the config asks for code that is gone, and the
// one line names the key, the value and the commit to build. A --set is named as the source.
TEST(ConfigVersions, RetiredKeysAtTheirValueGoOtherwiseAreRefused) {
  YAML::Node old = YAML::Load(R"(
race: {goal_origin: center, observe_team_lanes: false, lane_error_average_s: 0, governor_sets_throttle_at_cap: false,
       governor_band_mach: 0.04, preview_on_line: false, lane_scales_with_radius: false, w_tube_wall: 0,
       w_track_progress: 0,
       tube_wall_frac: 0.80000000000000004, governor_holds: mach, n_env: 4}
ll: {inference: eigen, normalize_returns: false, init_at_trim: false}
hl: {explore: aircraft, team_explore_scale: 1.0, critic: shared, team_target: sum, lateral: aircraft, inference: eigen}
train: {hl_average_share: 0, ll_both_teams: false, ll_choice_snapshots: 0, ll_choice_races: 384, ll_residual_scale: 0.5,
        ll_pilot: ppo}
pool: {p_center: 0.0, p_autopilot: 0}
)");
  migrate(old, "cfg.yaml", Written::kByUser);
  EXPECT_EQ(emitted(old), "race: {n_env: 4}\nll: {}\nhl: {}\ntrain: {ll_pilot: ppo}\npool: {}");
  const std::string gone = " was removed, measured not to help (this build behaves as ";
  EXPECT_EQ(error_of("hl: {explore: team}"), "cfg.yaml: hl.explore: team" + gone + "aircraft); build commit b8c9f8c to use it");
  EXPECT_EQ(error_of("train: {ll_choice_snapshots: 4}"),
            "cfg.yaml: train.ll_choice_snapshots: 4" + gone + "0); build commit f91e291 to use it");
  EXPECT_EQ(error_of("race: {w_tube_wall: 0.15}"), "cfg.yaml: race.w_tube_wall: 0.15" + gone + "0); build commit 833c6d1 to use it");
  EXPECT_EQ(error_of("race: {w_track_progress: 0.1}"),
            "cfg.yaml: race.w_track_progress: 0.1" + gone + "0); build commit 9d0d451 to use it");
  EXPECT_EQ(error_of("pool: {p_autopilot: 0.25}"), "cfg.yaml: pool.p_autopilot: 0.25" + gone + "0); build commit e9c8edf to use it");
  // A removed value of a key that stays: train.ll_pilot residual.
  EXPECT_EQ(error_of("train: {ll_pilot: residual}"),
            "cfg.yaml: train.ll_pilot: residual was removed, measured not to help; build commit 5761eb7 to use it");
  YAML::Node set = YAML::Load("race: {n_env: 4}");
  io::apply_override(set, "race.governor_holds=airspeed");
  try {
    migrate(set, "cfg.yaml", Written::kByUser);
    ADD_FAILURE() << "a retired key at another value was taken";
  } catch (const io::ConfigError& e) {
    EXPECT_EQ(std::string(e.what()).rfind("--set race.governor_holds=airspeed: race.governor_holds: airspeed", 0), 0u)
        << e.what();
  }
  // Not a mapping, or an empty section: left for the strict reader to name.
  EXPECT_EQ(error_of("[1, 2]"), "");
  EXPECT_EQ(error_of("race: ~\n", Written::kByTrain), "");
}

}  // namespace
}  // namespace f16race::config_versions
