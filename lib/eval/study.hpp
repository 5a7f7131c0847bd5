#pragma once
// The Fig. 3 study (issue 14): every (variant x seed x HL interval) training run a study config
// lists, each in its own run folder under the study's output folder, and a tournament per HL
// interval. This file holds the plan and the state of each cell (what is done, what resumes); the
// `f16race study` command runs the trainings as child processes; eval/study_report writes the
// report.
#include <cstdint>
#include <string>
#include <vector>

#include "eval/tournament.hpp"

namespace f16race::eval {

struct StudyConfig {
  std::string base_config = "configs/default.yaml";  // every run's config before the cell's keys
  std::vector<std::string> set;  // KEY=VALUE overrides of base_config for every run, as train's --set
  std::vector<std::string> variants{"es", "es_d1", "es_d2", "es_d3"};
  std::vector<int> seeds{1, 2, 3};
  std::vector<double> dt_hl_s{8.0, 20.0};
  std::uint64_t total_env_steps = 3500000;  // per run
  int jobs = 2;                 // trainings at once, one thread each
  int races_per_pair = 64;      // per pair of entries in each interval's tournament
  bool controls = true;         // RUN@center and RUN@random entries (never in the statistics)
  std::uint64_t tournament_seed = 1;
};

// Reads and validates a study config (io::ConfigError naming the file and key). Relative
// base_config paths are taken as given (relative to the working directory, like `train`).
StudyConfig read_study_config(const std::string& path);

struct StudyCell {
  std::string variant;
  int seed = 0;
  double dt_hl_s = 0.0;
  std::string run_dir;                 // OUT/dt<interval>/<variant>_s<seed>
  std::vector<std::string> overrides;  // --set assignments on top of base_config
};

// Cells in the order they train: interval, then seed, then variant (so an interrupted study has
// whole seeds of every variant first, the comparison the study is for).
std::vector<StudyCell> plan_study(const StudyConfig& config, const std::string& out_dir);

// OUT/dt8, OUT/dt20: the folder of one HL interval (its runs and its tournament).
std::string interval_dir(const std::string& out_dir, double dt_hl_s);
std::string interval_name(double dt_hl_s);  // "dt8", "dt20", "dt12.5"

enum class CellState { fresh, partial, finished };
struct CellStatus {
  CellState state = CellState::fresh;
  std::int64_t env_steps = 0;   // at the latest checkpoint
  std::int64_t total_env_steps = 0;
  double wall_s = 0.0;          // training time so far, its tail members' included
  // With train.hl_tail_members K > 1 the cell also trains K - 1 tails after its run, from a fork
  // where its HL-only tail starts (nominally tail_start_env_steps).
  int tail_members = 1;
  std::int64_t tail_start_env_steps = 0;
};

// The state of a cell's run folder. Throws io::InputError when the folder holds a run of another
// configuration (the study config or the base config changed since it was trained) or a run
// whose checkpoint cannot be read, naming the folder and the fix.
CellStatus cell_status(const StudyConfig& config, const StudyCell& cell);
// A cell's whole training in env steps, read from its metrics.csv files: its run's budget plus
// each tail member's tail (`total`), and how much of it is done.
struct CellWork {
  std::int64_t done = 0, total = 0;
};
CellWork cell_work(const CellStatus& status, const std::string& run_dir);

// A column of RUN/metrics.csv's last complete row (0 without one, or when a running writer has
// not finished the line): the study's progress and compute time.
inline constexpr int kMetricsEnvStepsColumn = 2, kMetricsWallColumn = 3;
double last_metrics_value(const std::string& run_dir, int column);
// The same column of the last complete row with at most `env_steps` env steps (0 without one).
double metrics_value_at(const std::string& run_dir, int column, std::int64_t env_steps);

// The `train` arguments that start (fresh) or continue (partial) a cell, after the executable.
std::vector<std::string> cell_train_args(const StudyConfig& config, const StudyCell& cell, CellState state);

// The tournament of one interval: its finished runs, controls as configured, into
// OUT/dt<interval>/tournament.
TournamentOptions interval_tournament(const StudyConfig& config, const std::vector<StudyCell>& cells,
                                      double dt_hl_s, const std::string& out_dir);

// The `tournament` arguments (after the executable and its --threads) that race `options` as
// the study sets them (interval_tournament: runs, races, seed, controls; every other option at
// its default, as `tournament` has it).
std::vector<std::string> tournament_args(const TournamentOptions& options);

}  // namespace f16race::eval
