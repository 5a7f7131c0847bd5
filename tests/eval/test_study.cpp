// The Fig. 3 study's plan and cell states: config validation, cell order, folders and train
// arguments, and fresh -> partial -> finished on a tiny real run (a changed config refused).
#include <gtest/gtest.h>

#include <algorithm>
#include <filesystem>
#include <fstream>
#include <string>

#include "eval/study.hpp"
#include "eval/study_report.hpp"
#include "io/input_error.hpp"
#include "io/yaml_config.hpp"
#include "train/train_config.hpp"
#include "train/trainer.hpp"
#include "support/temp_paths.hpp"

namespace f16race::eval {
namespace {

namespace fs = std::filesystem;

fs::path fresh_dir(const std::string& name) {
  const fs::path d = test_support::fresh_temp_path("study_" + name);
  fs::create_directories(d);
  return d;
}

void write(const fs::path& p, const std::string& text) { std::ofstream(p) << text; }

const char* kTinyBase = R"(
config_version: 1  # the tiny runs these tests were written for: version 1's defaults
race: {n_env: 2, team_size: 2, time_limit_s: 10.0, dt_hl_s: 1.6, track: {n_waypoints: 5}}
ll: {n_steps: 8, n_minibatches: 2, n_epochs: 1, hidden: [8, 8], d_model: 8, n_heads: 2}
hl: {hidden: [8, 8], d_model: 8, n_heads: 2, n_atoms: 11, n_steps_per_update: 1}
train: {total_env_steps: 100, ll_phase_updates: 1, hl_phase_updates: 1}
)";

TEST(Study, ConfigIsValidatedWithTheKeyNamed) {
  const fs::path d = fresh_dir("config");
  write(d / "base.yaml", kTinyBase);
  const std::string base = "base_config: " + (d / "base.yaml").string() + "\n";
  write(d / "ok.yaml", base + "variants: [es_d2, es_d3]\nseeds: [4, 7]\ndt_hl_s: [1.6, 4]\ntotal_env_steps: 5000\n");
  const StudyConfig c = read_study_config((d / "ok.yaml").string());
  EXPECT_EQ(c.variants, (std::vector<std::string>{"es_d2", "es_d3"}));
  EXPECT_EQ(c.seeds, (std::vector<int>{4, 7}));
  EXPECT_EQ(c.total_env_steps, 5000u);
  const auto error_of = [&](const std::string& body) {
    write(d / "bad.yaml", base + body);
    try {
      read_study_config((d / "bad.yaml").string());
    } catch (const io::ConfigError& e) {
      return std::string(e.what());
    }
    return std::string("no error");
  };
  EXPECT_NE(error_of("seeds: [1, 2, 1]\n").find("seeds"), std::string::npos);
  EXPECT_NE(error_of("variants: [es, es_d9]\n").find("es_d9"), std::string::npos);
  EXPECT_NE(error_of("dt_hl_s: [8, 8.0]\n").find("dt8 is listed twice"), std::string::npos);
  EXPECT_NE(error_of("jobz: 2\n").find("jobz"), std::string::npos);
  EXPECT_NE(error_of("total_env_steps: 10\n").find("total_env_steps"), std::string::npos);
  EXPECT_NE(error_of("set: [train.ll_pilot]\n").find("'train.ll_pilot' is not KEY=VALUE"), std::string::npos);
  EXPECT_NE(error_of("set: [train.ll_pilot=pid]\n").find("train.ll_pilot"), std::string::npos);  // checked on the base
  write(d / "set.yaml", base + "set: [train.ll_pilot=autopilot]\ndt_hl_s: [1.6]\n");
  // Every cell is checked on the base, not only the base: 20 s intervals do not fit its 10 s races.
  EXPECT_NE(error_of("dt_hl_s: [1.6, 20]\n").find("cell dt20/es_s1 is not a valid training config"), std::string::npos)
      << error_of("dt_hl_s: [1.6, 20]\n");
  EXPECT_EQ(read_study_config((d / "set.yaml").string()).set, (std::vector<std::string>{"train.ll_pilot=autopilot"}));
  write(d / "badbase.yaml", "race: {n_envs: 2}\n");
  write(d / "bad.yaml", "base_config: " + (d / "badbase.yaml").string() + "\n");
  EXPECT_THROW(read_study_config((d / "bad.yaml").string()), io::ConfigError);  // the base is checked too
  // ...and every cell on it: a base that pins race.seed fits seed 1's cells only.
  write(d / "seeded.yaml", std::string(kTinyBase) + "seed: 1\n");
  {
    YAML::Node n = YAML::LoadFile((d / "seeded.yaml").string());
    n["race"]["seed"] = 1;
    std::ofstream(d / "seeded.yaml") << n;
  }
  write(d / "bad.yaml", "base_config: " + (d / "seeded.yaml").string() + "\nseeds: [1, 2]\ndt_hl_s: [1.6]\n");
  const std::string e = [&] {
    try {
      read_study_config((d / "bad.yaml").string());
    } catch (const io::ConfigError& err) {
      return std::string(err.what());
    }
    return std::string("no error");
  }();
  EXPECT_NE(e.find("bad.yaml: cell dt1.6/es_s2 is not a valid training config: "), std::string::npos) << e;
  EXPECT_NE(e.find("race.seed = 1 differs from seed = 2"), std::string::npos) << e;
}

TEST(Study, PlanOrdersCellsByIntervalSeedVariant) {
  StudyConfig c;
  c.variants = {"es", "es_d3"};
  c.seeds = {2, 5};
  c.dt_hl_s = {8.0, 20.0};
  c.total_env_steps = 7000;
  const auto cells = plan_study(c, "OUT");
  ASSERT_EQ(cells.size(), 8u);
  EXPECT_EQ(cells[0].run_dir, "OUT/dt8/es_s2");
  EXPECT_EQ(cells[1].run_dir, "OUT/dt8/es_d3_s2");
  EXPECT_EQ(cells[2].run_dir, "OUT/dt8/es_s5");
  EXPECT_EQ(cells[7].run_dir, "OUT/dt20/es_d3_s5");
  EXPECT_EQ(cells[7].overrides, (std::vector<std::string>{"hl.agent=es_d3", "seed=5", "race.dt_hl_s=20",
                                                           "train.total_env_steps=7000"}));
  const auto fresh = cell_train_args(c, cells[0], CellState::fresh);
  EXPECT_NE(std::find(fresh.begin(), fresh.end(), "--overwrite"), fresh.end());
  EXPECT_NE(std::find(fresh.begin(), fresh.end(), "race.dt_hl_s=8"), fresh.end());
  EXPECT_EQ(cell_train_args(c, cells[0], CellState::partial),
            (std::vector<std::string>{"--threads", "1", "train", "--resume", "OUT/dt8/es_s2", "--quiet"}));
  const TournamentOptions t = interval_tournament(c, cells, 20.0, "OUT");
  EXPECT_EQ(t.runs, (std::vector<std::string>{"OUT/dt20/es_s2", "OUT/dt20/es_d3_s2", "OUT/dt20/es_s5",
                                               "OUT/dt20/es_d3_s5"}));
  EXPECT_EQ(t.out_dir, "OUT/dt20/tournament");
  // The child `tournament` the study starts races exactly these options (the rest at the CLI's
  // defaults, which are TournamentOptions'), so its done.txt matches what the study checks.
  std::vector<std::string> args{"tournament", "--runs", "OUT/dt20/es_s2", "OUT/dt20/es_d3_s2", "OUT/dt20/es_s5",
                                 "OUT/dt20/es_d3_s5", "--races", std::to_string(c.races_per_pair), "--seed",
                                 std::to_string(c.tournament_seed), "--out", "OUT/dt20/tournament"};
  if (c.controls) args.push_back("--controls");
  EXPECT_EQ(tournament_args(t), args);
  EXPECT_EQ(t.controls, c.controls);
  EXPECT_EQ(interval_name(12.5), "dt12.5");
  // The study's own overrides come first, so a cell's keys win over them.
  c.set = {"train.ll_pilot=autopilot"};
  EXPECT_EQ(plan_study(c, "OUT")[7].overrides,
            (std::vector<std::string>{"train.ll_pilot=autopilot", "hl.agent=es_d3", "seed=5", "race.dt_hl_s=20",
                                      "train.total_env_steps=7000"}));
}

// OUT/report/ is replaced whole: only the report's own files may be in it.
TEST(Study, ReportFolderOwnsItsFilesOnly) {
  for (const char* f : {"report.md", "curves_dt8.png", "curves_dt8.gp", "curves_dt12.5.png"})
    EXPECT_TRUE(is_study_report_output(f)) << f;
  for (const char* f : {"notes.md", "report_dt20.md", "curves_dt8.csv", "study.yaml", "dt8"})
    EXPECT_FALSE(is_study_report_output(f)) << f;
}

TEST(Study, MetricsTailSkipsALineStillBeingWritten) {
  const fs::path d = fresh_dir("tail");
  write(d / "metrics.csv", "update,phase_hl,env_steps,wall_s\n1,0,100,2.5\n2,0,200,5.0\n3,0,3");
  EXPECT_EQ(last_metrics_value(d.string(), kMetricsEnvStepsColumn), 200.0);
  EXPECT_EQ(last_metrics_value(d.string(), kMetricsWallColumn), 5.0);
  EXPECT_EQ(last_metrics_value((d / "none").string(), kMetricsWallColumn), 0.0);  // no file yet
}

// A study stopped while a cell's tail member trained finds the run itself at its budget: the
// cell stays partial (the study then resumes it, and `train --resume` finishes the members)
// until every member has reached the budget too.
TEST(Study, CellWithAnUnfinishedTailMemberIsPartial) {
  const fs::path d = fresh_dir("members");
  write(d / "base.yaml", kTinyBase);
  StudyConfig c;
  c.base_config = (d / "base.yaml").string();
  c.set = {"train.hl_tail_share=0.5", "train.hl_tail_members=3"};
  c.variants = {"es_d3"};
  c.seeds = {1};
  c.dt_hl_s = {1.6};
  c.total_env_steps = 600;
  const StudyCell cell = plan_study(c, (d / "out").string()).front();
  const train::TrainConfig cfg =
      train::read_train_config(io::load_yaml_with_overrides(c.base_config, cell.overrides), c.base_config);
  {
    train::Trainer t(cfg, cell.run_dir);
    ASSERT_GE(t.run().env_steps, 600);  // the run's own budget; its members forked, not trained
  }
  const CellStatus forked = cell_status(c, cell);
  EXPECT_EQ(forked.state, CellState::partial);
  EXPECT_GE(forked.env_steps, 600);
  // The cell's work: the run's 600 env steps and two tails from the fork, at the first update
  // that began at or past the nominal start (300).
  EXPECT_EQ(forked.tail_start_env_steps, 300);
  const CellWork at_fork = cell_work(forked, cell.run_dir);
  const std::int64_t tail = (at_fork.total - 600) / 2;
  EXPECT_EQ(at_fork.total, 600 + 2 * tail);
  EXPECT_GT(tail, 200);
  EXPECT_LE(tail, 300);
  EXPECT_EQ(at_fork.done, 600);
  const double run_wall = forked.wall_s;
  EXPECT_GT(run_wall, 0.0);
  train::Trainer::resume((fs::path(cell.run_dir) / "members" / "1").string())->run();
  EXPECT_EQ(cell_work(forked, cell.run_dir).done, 600 + tail);
  train::Trainer::resume((fs::path(cell.run_dir) / "members" / "2").string())->run(nullptr, 1);
  const CellStatus part = cell_status(c, cell);
  EXPECT_EQ(part.state, CellState::partial);  // member 2 stopped part way
  EXPECT_GT(cell_work(part, cell.run_dir).done, 600 + tail);
  EXPECT_LT(cell_work(part, cell.run_dir).done, at_fork.total);
  train::train_tail_members(cell.run_dir);
  const CellStatus done = cell_status(c, cell);
  EXPECT_EQ(done.state, CellState::finished);
  EXPECT_EQ(cell_work(done, cell.run_dir).done, at_fork.total);
  // Its compute time counts the members' training, not their copy of the run's rows.
  EXPECT_GT(done.wall_s, run_wall);
  EXPECT_LT(done.wall_s, 3.0 * run_wall + 60.0);
  fs::remove_all(fs::path(cell.run_dir) / "members" / "2");
  EXPECT_EQ(cell_status(c, cell).state, CellState::partial);
}

TEST(Study, MetricsValueAtAnEnvStepCount) {
  const fs::path d = fresh_dir("at");
  write(d / "metrics.csv", "update,phase_hl,env_steps,wall_s\n1,0,100,2.5\n2,0,200,5.0\n3,0,300,7.5\n");
  EXPECT_EQ(metrics_value_at(d.string(), kMetricsWallColumn, 299), 5.0);
  EXPECT_EQ(metrics_value_at(d.string(), kMetricsWallColumn, 300), 7.5);
  EXPECT_EQ(metrics_value_at(d.string(), kMetricsWallColumn, 99), 0.0);  // no row so early
}

TEST(Study, CellStateFollowsTheRunAndRefusesAnotherConfig) {
  const fs::path d = fresh_dir("cells");
  write(d / "base.yaml", kTinyBase);
  StudyConfig c;
  c.base_config = (d / "base.yaml").string();
  c.variants = {"es_d3"};
  c.seeds = {1};
  c.dt_hl_s = {1.6};
  c.total_env_steps = 1000;
  const StudyCell cell = plan_study(c, (d / "out").string()).front();
  EXPECT_EQ(cell_status(c, cell).state, CellState::fresh);
  fs::create_directories(cell.run_dir);
  write(fs::path(cell.run_dir) / "config.yaml", "leftover of a run that never checkpointed\n");
  EXPECT_EQ(cell_status(c, cell).state, CellState::fresh);  // nothing to keep: train --overwrite moves it aside
  fs::remove_all(cell.run_dir);
  const train::TrainConfig cfg =
      train::read_train_config(io::load_yaml_with_overrides(c.base_config, cell.overrides), c.base_config);
  {
    train::Trainer t(cfg, cell.run_dir);
    t.run(nullptr, 2);
  }
  const CellStatus partial = cell_status(c, cell);
  EXPECT_EQ(partial.state, CellState::partial);
  EXPECT_GT(partial.env_steps, 0);
  EXPECT_LT(partial.env_steps, 1000);
  EXPECT_GT(partial.wall_s, 0.0);
  train::Trainer::resume(cell.run_dir)->run();
  const CellStatus done = cell_status(c, cell);
  EXPECT_EQ(done.state, CellState::finished);
  EXPECT_GE(done.env_steps, 1000);
  {
    // A run trained before a config key existed (its config.yaml lacks it, its checkpoint hashes
    // that text) is still its cell's run when the key's default is what the cell asks for.
    const fs::path yaml = fs::path(cell.run_dir) / "config.yaml";
    std::ifstream in(yaml);
    std::string text, line;
    while (std::getline(in, line))
      if (line.find("time_limit_terminal") == std::string::npos) text += line + "\n";
    in.close();
    ASSERT_NE(text.size(), fs::file_size(yaml)) << "the key to drop is not in config.yaml";
    write(yaml, text);
    const fs::path ckpt = fs::path(cell.run_dir) / "checkpoint" / train::latest_checkpoint_name(cell.run_dir);
    std::ifstream meta_in(ckpt / "meta.yaml");
    std::string meta, m;
    while (std::getline(meta_in, m))
      meta += (m.rfind("config_hash:", 0) == 0 ? "config_hash: " + std::to_string(train::config_hash(text)) : m) + "\n";
    meta_in.close();
    write(ckpt / "meta.yaml", meta);
    EXPECT_EQ(cell_status(c, cell).state, CellState::finished);
  }
  StudyConfig other = c;
  other.total_env_steps = 2000;  // the study changed: this folder is not its cell's run
  EXPECT_THROW(cell_status(other, plan_study(other, (d / "out").string()).front()), io::InputError);
}

}  // namespace
}  // namespace f16race::eval
