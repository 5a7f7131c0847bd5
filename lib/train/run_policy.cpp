#include "train/run_policy.hpp"

#include <torch/torch.h>

#include <filesystem>
#include <fstream>
#include <iterator>
#include <stdexcept>

#include "io/atomic_file.hpp"
#include "io/input_error.hpp"
#include "train/obs_views.hpp"
#include "train/policy_rows.hpp"
#include "train/trainer.hpp"

namespace f16race::train {

namespace fs = std::filesystem;

namespace {

std::string folder_name(const std::string& dir) {
  const fs::path p(dir);
  const std::string name = p.filename().string();
  return name.empty() ? p.parent_path().filename().string() : name;
}

RunPolicy make_policy(TrainConfig cfg) {
  RunPolicy p;
  p.dims = obs_dims(cfg.race);
  cfg.ll.net.dims = p.dims;
  cfg.hl.dims = p.dims;
  cfg.ll.total_updates = 1;  // only the learning-rate schedule reads it
  p.config = cfg;
  p.ll = std::make_unique<agents::PpoAgent>(cfg.ll);
  p.hl = std::make_unique<agents::EsAgent>(cfg.hl);
  return p;
}

// m's high level joins p's ensemble: refused unless both fly one low level with critics of one kind.
void add_hl_member(RunPolicy& p, RunPolicy m) {
  check_same_race_shape(p, m);
  // One low level flies every decision: the members' values are only comparable for it.
  if (io::read_file((fs::path(m.checkpoint_dir) / "ll.pt").string()) != io::read_file((fs::path(p.checkpoint_dir) / "ll.pt").string()))
    throw io::InputError(m.checkpoint_dir + "/ll.pt: another low level than " + p.checkpoint_dir +
                         "/ll.pt; an ensemble joins high levels trained against one low level");
  if (m.config.hl.variant != p.config.hl.variant || m.config.hl.n_bins != p.config.hl.n_bins)
    throw io::InputError(m.run_dir + ": another high-level variant or bin count than " + p.run_dir +
                         "; an ensemble joins critics of one kind");
  p.hl_members.push_back(std::move(m.hl));
}

}  // namespace

RunPolicy load_run_policy(const std::string& run_dir) {
  const RunConfig run = read_run_config(run_dir);
  const std::string name = latest_checkpoint_name(run_dir);
  if (name.empty())
    throw io::InputError(run_dir + "/checkpoint/LATEST: missing, so the run has no checkpoint yet; train it first");
  const fs::path dir = fs::path(run_dir) / "checkpoint" / name;
  RunPolicy p = make_policy(run.config);
  p.name = folder_name(run_dir);
  p.run_dir = run_dir;
  p.checkpoint_dir = dir.string();
  std::string step = "meta.yaml";
  try {
    p.env_steps = check_checkpoint_meta(dir.string(), run.hash, CheckpointUse::policy);
    step = "ll.pt";
    p.ll->load((dir / "ll.pt").string());
    step = "hl.pt";
    p.hl->load((dir / "hl.pt").string());
  } catch (const std::exception& e) {
    throw io::InputError((dir / step).string() + ": cannot load the policy (" + checkpoint_error_reason(e) +
                             "); the file is corrupt, truncated or from another build: restore it or train again");
  }
  // train.hl_tail_members: a finished run's policy is the ensemble of its tails (a run still
  // training is evaluated as it stands: its members come at its end).
  if (p.config.loop.hl_tail_members > 1 && p.env_steps >= p.config.loop.total_env_steps) {
    if (const std::string why = unfinished_tail_member(run_dir, p.config); !why.empty()) throw io::InputError(why);
    for (int m = 1; m < p.config.loop.hl_tail_members; ++m) add_hl_member(p, load_run_policy(member_dir(run_dir, m)));
  }
  return p;
}

RunPolicy load_ensemble_policy(const std::vector<std::string>& run_dirs) {
  if (run_dirs.size() < 2) throw io::InputError("an ensemble needs at least two run folders joined by '+'");
  RunPolicy p = load_run_policy(run_dirs.front());
  for (std::size_t k = 1; k < run_dirs.size(); ++k) {
    RunPolicy m = load_run_policy(run_dirs[k]);
    p.name += "+" + m.name;
    add_hl_member(p, std::move(m));
  }
  return p;
}

RunPolicy load_policy_spec(const std::string& spec) {
  if (spec.find('+') == std::string::npos || fs::exists(spec)) return load_run_policy(spec);
  std::vector<std::string> dirs;
  for (std::size_t start = 0;;) {
    const std::size_t plus = spec.find('+', start);
    dirs.push_back(spec.substr(start, plus - start));
    if (plus == std::string::npos) break;
    start = plus + 1;
  }
  for (const std::string& d : dirs)
    if (d.empty()) throw io::InputError(spec + ": an empty run folder in an ensemble; join run folders as RUN+RUN");
  return load_ensemble_policy(dirs);
}

void check_same_race_shape(const RunPolicy& reference, const RunPolicy& other) {
  // The same bins mean other goals in another frame: such a run would fly other lanes than it learned.
  if (reference.config.race.goal_frame != other.config.race.goal_frame)
    throw io::InputError(other.run_dir + ": trained with another race.goal_frame than " + reference.run_dir +
                             "; race runs trained with the same goal frame");
  const auto& a = reference.dims;
  const auto& b = other.dims;
  if (reference.config.race.team_size == other.config.race.team_size && a.d_task == b.d_task && a.d_ego == b.d_ego &&
      a.d_ado == b.d_ado)
    return;
  auto shape = [](const RunPolicy& p) {
    return std::to_string(p.config.race.team_size) + " vs " + std::to_string(p.config.race.team_size) +
           " races with task size " + std::to_string(p.dims.d_task) + " and ado size " + std::to_string(p.dims.d_ado);
  };
  throw io::InputError(other.run_dir + ": trained on " + shape(other) + ", but " + reference.run_dir + " on " +
                           shape(reference) + "; race runs trained for the same race.team_size and race.preview_points");
}

void greedy_ll_actions(const RunPolicy& p, const race::RaceEnv& env, const models::LlObs& obs,
                       const torch::Tensor& rows, at::Generator& gen, float* actions) {
  if (rows.numel() == 0) return;
  if (p.config.loop.ll_pilot == LowLevelPilot::kAutopilot) {
    race::autopilot_actions(env, goal_lane_autopilot(p.config), actions, rows.data_ptr<std::int64_t>(), rows.numel());
    return;
  }
  scatter_rows(rows, p.ll->act(obs, rows, gen, false).mean, actions);  // the Gaussian's mean
  apply_ll_throttle(p.config, rows.data_ptr<std::int64_t>(), rows.numel(), actions);
}

void apply_ll_throttle(const TrainConfig& config, const std::int64_t* rows, std::int64_t n_rows, float* actions) {
  if (config.loop.ll_throttle != LowLevelThrottle::kGovernor) return;
  for (std::int64_t k = 0; k < n_rows; ++k) actions[(rows ? rows[k] : k) * race::kActionDim] = 1.0f;
}

void policy_hl_bins(const RunPolicy& p, const models::HlObs& obs, const torch::Tensor& rows, double epsilon,
                    at::Generator& gen, std::int64_t* bins) {
  if (rows.numel() == 0) return;
  // Each critic reads the rows in place (q_values(index_rows(obs, rows)) bit for bit).
  torch::Tensor q = p.hl->q_values(obs, rows);
  if (!p.hl_members.empty()) {
    for (const auto& m : p.hl_members) q = q + m->q_values(obs, rows);
    q = q / static_cast<double>(p.hl_members.size() + 1);
  }
  scatter_rows(rows, p.hl->choose(q, epsilon, gen).bins, bins);
}

RunPolicy untrained_policy(const TrainConfig& config, std::uint64_t seed) {
  torch::manual_seed(seed);  // the initial weights
  RunPolicy p = make_policy(config);
  p.name = "untrained";
  return p;
}

}  // namespace f16race::train
