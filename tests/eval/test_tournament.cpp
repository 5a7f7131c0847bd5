// Tournament bookkeeping on two tiny trained runs plus the untrained entry: every race counted
// once, sides swapped in half, wins and losses consistent, reports written, bad runs refused.
#include <gtest/gtest.h>
#include <yaml-cpp/yaml.h>

#include <filesystem>
#include <fstream>

#include "eval/tournament.hpp"
#include "io/yaml_config.hpp"
#include "train/trainer.hpp"

namespace f16race::eval {
namespace {

namespace fs = std::filesystem;

std::string trained_run(const std::string& name, int seed, int team_size = 2) {
  const fs::path dir = fs::temp_directory_path() / ("f16race_tour_" + name);
  fs::remove_all(dir);
  YAML::Node root = YAML::Load(R"(
race: {n_env: 2, time_limit_s: 10.0, dt_hl_s: 1.6, track: {n_waypoints: 5}}
ll: {n_steps: 8, n_minibatches: 2, n_epochs: 1, hidden: [8, 8], d_model: 8, n_heads: 2}
hl: {hidden: [8, 8], d_model: 8, n_heads: 2, n_atoms: 11, n_steps_per_update: 1}
train: {total_env_steps: 100, ll_phase_updates: 1, hl_phase_updates: 1}
)");
  io::apply_override(root, "seed=" + std::to_string(seed));
  io::apply_override(root, "race.team_size=" + std::to_string(team_size));
  train::Trainer t(train::read_train_config(root, "test"), dir.string());
  t.run(nullptr, 2);
  return dir.string();
}

TEST(Tournament, CountsEveryRaceOnceWithSidesSwapped) {
  TournamentOptions o;
  o.runs = {trained_run("a", 1), trained_run("b", 2)};
  o.races_per_pair = 6;
  o.batch_envs = 7;  // batches straddle pairs
  o.bootstrap_replicates = 200;
  o.out_dir = (fs::temp_directory_path() / "f16race_tour_out").string();
  fs::remove_all(o.out_dir);
  const TournamentResult r = run_tournament(o);
  ASSERT_EQ(r.entries.size(), 3u);  // two runs and the untrained networks
  EXPECT_EQ(r.entries[2].name, "untrained");
  EXPECT_EQ(r.races.size(), 3u * 6u);
  for (int i = 0; i < 3; ++i)
    for (int j = 0; j < 3; ++j) {
      if (i == j) continue;
      EXPECT_EQ(r.games[i][j], 6.0);
      EXPECT_DOUBLE_EQ(r.wins[i][j] + r.wins[j][i], r.games[i][j]);
    }
  int blue_first[3] = {};
  for (const RaceRecord& x : r.races) {
    EXPECT_NE(x.blue, x.red);
    EXPECT_GT(x.duration_s, 0.0);
    blue_first[x.pair] += x.blue < x.red;
  }
  for (int p : blue_first) EXPECT_EQ(p, 3);
  write_tournament_report(r, o);
  for (const char* f : {"races.csv", "pairings.csv", "summary.json", "summary.md", "tournament.gp"})
    EXPECT_TRUE(fs::exists(fs::path(o.out_dir) / f)) << f;
  {
    std::ifstream md(o.out_dir + "/summary.md");
    const std::string text((std::istreambuf_iterator<char>(md)), {});
    EXPECT_NE(text.find("| untrained | untrained | 1 | 12 |"), std::string::npos) << text;  // 6 races x 2 opponents
  }
  const YAML::Node js = YAML::LoadFile(o.out_dir + "/summary.json");
  ASSERT_EQ(js["variants"].size(), 2u);  // es_d3 (2 runs) and untrained
  for (const auto& v : js["variants"]) {
    const double lo = v["iqm_ci95"][0].as<double>(), hi = v["iqm_ci95"][1].as<double>();
    EXPECT_LE(lo, v["iqm"].as<double>() + 1e-12);
    EXPECT_GE(hi, v["iqm"].as<double>() - 1e-12);
  }
}

TEST(Tournament, RefusesMissingAndMismatchedRuns) {
  TournamentOptions o;
  o.runs = {"/nonexistent/run"};
  try {
    run_tournament(o);
    FAIL();
  } catch (const std::runtime_error& e) {
    EXPECT_NE(std::string(e.what()).find("/nonexistent/run: not a training run"), std::string::npos) << e.what();
  }
  o.runs = {trained_run("c", 3, 2), trained_run("d", 4, 1)};
  try {
    run_tournament(o);
    FAIL();
  } catch (const std::runtime_error& e) {
    EXPECT_NE(std::string(e.what()).find("f16race_tour_d: trained on 1 vs 1"), std::string::npos) << e.what();
  }
}

}  // namespace
}  // namespace f16race::eval
