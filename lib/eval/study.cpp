#include "eval/study.hpp"

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <filesystem>
#include <fstream>
#include <sstream>

#include "io/input_error.hpp"
#include "io/yaml_config.hpp"
#include "train/train_config.hpp"
#include "train/trainer.hpp"

namespace f16race::eval {

namespace fs = std::filesystem;

StudyConfig read_study_config(const std::string& path) {
  StudyConfig c;
  io::ConfigReader r(io::load_yaml_file(path), path);
  r.read("base_config", &c.base_config, {});
  r.read("set", &c.set, {});
  for (const std::string& kv : c.set)
    if (kv.find('=') == std::string::npos || kv.front() == '=')
      r.fail("set", "'" + kv + "' is not KEY=VALUE (e.g. train.ll_pilot=autopilot)");
  r.read("variants", &c.variants, {"es", "es_d1", "es_d2", "es_d3"});
  r.read("seeds", &c.seeds, 0, 1000000000);
  for (std::size_t i = 0; i < c.seeds.size(); ++i)
    for (std::size_t j = 0; j < i; ++j)
      if (c.seeds[i] == c.seeds[j]) r.fail("seeds", "seed " + std::to_string(c.seeds[i]) + " is listed twice");
  r.read("dt_hl_s", &c.dt_hl_s, 0.08, 600.0);
  for (std::size_t i = 0; i < c.dt_hl_s.size(); ++i)
    for (std::size_t j = 0; j < i; ++j)
      if (interval_name(c.dt_hl_s[i]) == interval_name(c.dt_hl_s[j]))
        r.fail("dt_hl_s", interval_name(c.dt_hl_s[i]) + " is listed twice");
  r.read("total_env_steps", &c.total_env_steps);
  // train reads the count as a signed 64-bit number: the study refuses what every cell would.
  if (c.total_env_steps < 1000 || c.total_env_steps > (std::uint64_t{1} << 62))
    r.fail("total_env_steps", "must be in [1000, 2^62]");
  r.read("jobs", &c.jobs, 1, 64);
  r.read("races_per_pair", &c.races_per_pair, 2, 1000000);
  r.read("controls", &c.controls);
  r.read("tournament_seed", &c.tournament_seed);
  r.finish();
  // The base config with the study's overrides must be a valid training config, and so must every
  // cell's (its seed, variant and interval on top): found now, not in the child hours later.
  train::read_train_config(io::load_yaml_with_overrides(c.base_config, c.set), c.base_config);
  for (const StudyCell& cell : plan_study(c, "")) {
    try {
      train::read_train_config(io::load_yaml_with_overrides(c.base_config, cell.overrides), c.base_config);
    } catch (const io::ConfigError& e) {
      throw io::ConfigError(path + ": cell " + interval_name(cell.dt_hl_s) + "/" + cell.variant + "_s" +
                            std::to_string(cell.seed) + " is not a valid training config: " + e.what());
    }
  }
  return c;
}

std::string interval_name(double dt_hl_s) {
  char buf[32];
  std::snprintf(buf, sizeof buf, "dt%g", dt_hl_s);
  return buf;
}

std::string interval_dir(const std::string& out_dir, double dt_hl_s) {
  return (fs::path(out_dir) / interval_name(dt_hl_s)).string();
}

std::vector<StudyCell> plan_study(const StudyConfig& config, const std::string& out_dir) {
  std::vector<StudyCell> cells;
  for (double dt : config.dt_hl_s)
    for (int seed : config.seeds)
      for (const std::string& v : config.variants) {
        StudyCell c;
        c.variant = v;
        c.seed = seed;
        c.dt_hl_s = dt;
        c.run_dir = (fs::path(interval_dir(out_dir, dt)) / (v + "_s" + std::to_string(seed))).string();
        char dt_text[32];
        std::snprintf(dt_text, sizeof dt_text, "%.17g", dt);
        c.overrides = config.set;
        for (const std::string& o : {"hl.agent=" + v, "seed=" + std::to_string(seed), std::string("race.dt_hl_s=") + dt_text,
                                     "train.total_env_steps=" + std::to_string(config.total_env_steps)})
          c.overrides.push_back(o);
        cells.push_back(c);
      }
  return cells;
}

namespace {
// Column `column` of a metrics.csv line, or NaN when the line has no such number.
double metrics_field(const std::string& line, int column) {
  std::stringstream ss(line);
  std::string field;
  for (int k = 0; k <= column && std::getline(ss, field, ','); ++k) {
  }
  try {
    return field.empty() ? NAN : std::stod(field);
  } catch (const std::exception&) {
    return NAN;
  }
}

// Calls `row` with each complete data row of RUN/metrics.csv (a line cut by a running writer
// has no newline yet and is skipped).
template <class Row>
void for_each_metrics_row(const std::string& run_dir, Row row) {
  std::ifstream in(run_dir + "/metrics.csv");
  std::string line;
  bool header = true;
  while (std::getline(in, line)) {
    if (!header && !line.empty() && !in.eof()) row(line);
    header = false;
  }
}
}  // namespace

double last_metrics_value(const std::string& run_dir, int column) {
  std::string last;
  for_each_metrics_row(run_dir, [&](const std::string& line) { last = line; });
  const double v = metrics_field(last, column);
  return std::isfinite(v) ? v : 0.0;
}

double metrics_value_at(const std::string& run_dir, int column, std::int64_t env_steps) {
  double v = 0.0;
  for_each_metrics_row(run_dir, [&](const std::string& line) {
    const double steps = metrics_field(line, kMetricsEnvStepsColumn), x = metrics_field(line, column);
    if (steps <= static_cast<double>(env_steps) && std::isfinite(x)) v = x;
  });
  return v;
}

namespace {
// The tail starts with the first update that begins in the run's last train.hl_tail_share:
// nominally at tail_start_env_steps, in fact where the update before it ended.
void set_cell_work(const train::TrainConfig& cfg, CellStatus* st) {
  const std::int64_t total = st->total_env_steps;
  st->tail_members = std::max(1, cfg.loop.hl_tail_members);
  st->tail_start_env_steps =
      st->tail_members > 1 ? static_cast<std::int64_t>((1.0 - cfg.loop.hl_tail_share) * static_cast<double>(total)) : total;
}

// Env steps of the run at its members' fork: its first metrics row at or past the tail's nominal
// start (the nominal start while the run has not reached it).
std::int64_t fork_env_steps(const CellStatus& st, const std::string& run_dir) {
  std::int64_t fork = -1;
  for_each_metrics_row(run_dir, [&](const std::string& line) {
    const double steps = metrics_field(line, kMetricsEnvStepsColumn);
    if (fork < 0 && steps >= static_cast<double>(st.tail_start_env_steps)) fork = static_cast<std::int64_t>(steps);
  });
  return fork < 0 ? st.tail_start_env_steps : std::min(fork, st.total_env_steps);
}

// The training time of a cell: its run's, plus each tail member's own (a member's metrics.csv
// starts with the run's rows up to the fork, whose wall time is the run's).
double cell_wall_s(const CellStatus& st, const std::string& run_dir) {
  double wall = last_metrics_value(run_dir, kMetricsWallColumn);
  const std::int64_t fork = st.tail_members > 1 ? fork_env_steps(st, run_dir) : 0;
  for (int m = 1; m < st.tail_members; ++m) {
    const std::string dir = train::member_dir(run_dir, m);
    const double own = last_metrics_value(dir, kMetricsWallColumn) - metrics_value_at(dir, kMetricsWallColumn, fork);
    wall += std::max(0.0, own);
  }
  return wall;
}
}  // namespace

CellWork cell_work(const CellStatus& st, const std::string& run_dir) {
  const auto steps = [](const std::string& dir) {
    return static_cast<std::int64_t>(last_metrics_value(dir, kMetricsEnvStepsColumn));
  };
  CellWork w;
  w.done = std::min(steps(run_dir), st.total_env_steps);
  w.total = st.total_env_steps;
  if (st.tail_members < 2) return w;
  const std::int64_t fork = fork_env_steps(st, run_dir), tail = st.total_env_steps - fork;
  w.total += (st.tail_members - 1) * tail;
  for (int m = 1; m < st.tail_members; ++m)
    w.done += std::clamp<std::int64_t>(steps(train::member_dir(run_dir, m)) - fork, 0, tail);
  return w;
}

CellStatus cell_status(const StudyConfig& config, const StudyCell& cell) {
  CellStatus st;
  st.total_env_steps = static_cast<std::int64_t>(config.total_env_steps);
  const train::TrainConfig want =
      train::read_train_config(io::load_yaml_with_overrides(config.base_config, cell.overrides), config.base_config);
  set_cell_work(want, &st);
  // A folder without a checkpoint holds nothing to keep: the cell starts afresh (train
  // --overwrite moves what is there aside).
  if (!fs::is_directory(cell.run_dir) || train::latest_checkpoint_name(cell.run_dir).empty()) return st;
  const train::RunConfig have = train::read_run_config(cell.run_dir);
  // Compared as this build reads both (defaults filled in), so a key added since the run was
  // trained, at its default, does not orphan the run; its checkpoint is still checked against
  // the run's own config.yaml below.
  if (train::train_config_yaml(have.config) != train::train_config_yaml(want))
    throw io::InputError(cell.run_dir +
                         ": holds a run of another configuration than this study cell (the study or base config "
                         "changed since it was trained); move the folder aside, or restore the config it was "
                         "trained with");
  const fs::path dir = fs::path(cell.run_dir) / "checkpoint" / train::latest_checkpoint_name(cell.run_dir);
  try {
    // A finished cell is only raced, so a checkpoint whose policy this build loads is enough;
    // resuming an unfinished one checks the resume format itself.
    st.env_steps = train::check_checkpoint_meta(dir.string(), have.hash, train::CheckpointUse::policy);
  } catch (const std::exception& e) {
    throw io::InputError((dir / "meta.yaml").string() + ": cannot read the checkpoint (" +
                         train::checkpoint_error_reason(e) + "); restore it, or move the run folder aside to retrain");
  }
  st.state = st.env_steps >= st.total_env_steps && train::unfinished_tail_member(cell.run_dir, have.config).empty()
                 ? CellState::finished
                 : CellState::partial;
  st.wall_s = cell_wall_s(st, cell.run_dir);
  return st;
}

std::vector<std::string> cell_train_args(const StudyConfig& config, const StudyCell& cell, CellState state) {
  if (state == CellState::partial) return {"--threads", "1", "train", "--resume", cell.run_dir, "--quiet"};
  std::vector<std::string> a{"--threads", "1", "train", "--config", config.base_config};
  for (const std::string& o : cell.overrides) {
    a.push_back("--set");
    a.push_back(o);
  }
  for (const char* s : {"--run", cell.run_dir.c_str(), "--quiet", "--overwrite"}) a.emplace_back(s);
  return a;
}

TournamentOptions interval_tournament(const StudyConfig& config, const std::vector<StudyCell>& cells,
                                      double dt_hl_s, const std::string& out_dir) {
  TournamentOptions o;
  for (const StudyCell& c : cells)
    if (interval_name(c.dt_hl_s) == interval_name(dt_hl_s)) o.runs.push_back(c.run_dir);
  o.controls = config.controls;
  o.races_per_pair = config.races_per_pair;
  o.seed = config.tournament_seed;
  o.out_dir = (fs::path(interval_dir(out_dir, dt_hl_s)) / "tournament").string();
  return o;
}

std::vector<std::string> tournament_args(const TournamentOptions& o) {
  std::vector<std::string> a{"tournament", "--runs"};
  a.insert(a.end(), o.runs.begin(), o.runs.end());
  for (const std::string& s : {std::string("--races"), std::to_string(o.races_per_pair), std::string("--seed"),
                               std::to_string(o.seed), std::string("--out"), o.out_dir})
    a.push_back(s);
  if (o.controls) a.emplace_back("--controls");
  return a;
}

}  // namespace f16race::eval
