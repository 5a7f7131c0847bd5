// A rank's trainer from its config: this rank's slice of the envs, the learners and the pool
// opponent's networks, the rollout's buffers and the random streams (then restored from a
// checkpoint at a resume, trainer_checkpoint.cpp).
#include <torch/torch.h>

#include <algorithm>
#include <filesystem>
#include <string>
#include <vector>

#include "agents/replicas.hpp"
#include "dist/process_group.hpp"
#include "io/atomic_file.hpp"
#include "train/trainer_state.hpp"

namespace f16race::train {

namespace fs = std::filesystem;
using models::HlObs;

void Trainer::State::build(bool fresh) {
  // Network initialisation draws from torch's global generator: seed it, once, here.
  torch::manual_seed(cfg.seed);
  pool = SnapshotPool(run_dir, cfg.pool.max_snapshots, writes());
  n_env_global = cfg.race.n_env;
  race::RaceConfig slice = cfg.race;
  if (world > 1) {
    if (cfg.race.n_env % world != 0)
      throw io::InputError("race.n_env = " + std::to_string(cfg.race.n_env) + " does not split evenly over " +
                           std::to_string(world) + " ranks: make it a multiple of " + std::to_string(world) +
                           " (each rank steps race.n_env / ranks envs)");
    slice.n_env = cfg.race.n_env / world;
  }
  // Global env ids: a rank's races are those envs of the group's batch (RaceEnv's first_env_id).
  env = std::make_unique<race::RaceEnv>(slice, rank * slice.n_env);
  n_env = env->n_env();
  n_agent = env->n_agent();
  ts = cfg.race.team_size;
  dims = obs_dims(*env);
  resolve_hl_scales(&cfg);
  cfg.ll.net.dims = dims;
  cfg.hl.dims = dims;
  build_learners();
  // Each rank its own streams (rank 0's are a single process's): actions, matchups.
  gen = models::make_generator(cfg.seed * 7919 + 3 + static_cast<std::uint64_t>(rank) * 1000003);
  stream = RandomStream(cfg.seed, 0xC0FFEE + static_cast<std::uint64_t>(rank));
  if (group != nullptr) {
    agents::Replicas replicas;
    dist::Group* g = group;
    replicas.sum_floats = [g](float* v, std::int64_t n) { g->allreduce_sum(v, static_cast<std::size_t>(n)); };
    replicas.sum_doubles = [g](double* v, std::int64_t n) { g->allreduce_sum(v, static_cast<std::size_t>(n)); };
    replicas.gather = [g](const std::vector<double>& v) { return g->allgather(v); };
    ppo->set_replicas(replicas);
    es->set_replicas(replicas);
  }
  side.assign(n_env, 0);
  vs_pool.assign(n_env, 0);
  ll_rows = PolicyRows(2, n_env * n_agent);
  hl_rows = PolicyRows(2, n_env * n_agent);
  ll_ret.assign(static_cast<std::size_t>(n_env) * ts, 0.0);
  hl_ret.assign(static_cast<std::size_t>(n_env) * ts, 0.0);
  open.open.assign(n_env, 0);
  open.obs = HlObs{torch::zeros({n_env, ts, dims.d_ego}), torch::zeros({n_env, ts, 3}),
                   torch::zeros({n_env, ts, dims.n_other, dims.d_ado}), torch::zeros({n_env, ts, dims.n_other}, torch::kBool),
                   torch::zeros({n_env, ts, dims.d_task})};
  open.actions = torch::zeros({n_env, ts, 3}, torch::kInt64);
  open.reward = torch::zeros({n_env, ts});
  open.active = torch::zeros({n_env, ts}, torch::kBool);
  if (fresh && !cfg.loop.ll_from.empty()) load_frozen_low_level();
  if (fresh && (cfg.loop.ll_pilot == LowLevelPilot::kAutopilot || !cfg.loop.ll_from.empty())) phase = 1;
  if (fresh)
    for (int e = 0; e < n_env; ++e) draw_matchup(e);
}

// The learners, the pool opponent's networks and the rollout buffer, from the resolved config.
void Trainer::State::build_learners() {
  // Planned PPO updates for the learning-rate schedule: the LL share of the step budget.
  const double ll_share = static_cast<double>(cfg.loop.ll_phase_updates) /
                          (cfg.loop.ll_phase_updates + cfg.loop.hl_phase_updates * cfg.hl.n_steps_per_update *
                                                           std::max(1.0, cfg.race.dt_hl_s / cfg.race.dt_ll_s) /
                                                           static_cast<double>(cfg.ll.n_steps));
  const double ll_steps = (1.0 - cfg.loop.hl_tail_share) * static_cast<double>(cfg.loop.total_env_steps);
  cfg.ll.total_updates =
      std::max<std::int64_t>(1, static_cast<std::int64_t>(ll_share * ll_steps / (cfg.ll.n_steps * n_env_global)) + 1);
  ppo = std::make_unique<agents::PpoAgent>(cfg.ll);
  es = std::make_unique<agents::EsAgent>(cfg.hl);
  opp_ppo = std::make_unique<agents::PpoAgent>(cfg.ll);
  opp_es = std::make_unique<agents::EsAgent>(cfg.hl);
  buffer = std::make_unique<agents::RolloutBuffer>(cfg.ll.n_steps, static_cast<std::int64_t>(n_env) * ts, dims,
                                                   race::kActionDim);
}

void Trainer::State::load_frozen_low_level() {
  const std::string& from = cfg.loop.ll_from;
  const std::string name = latest_checkpoint_name(from);
  if (name.empty())
    throw io::InputError(from + ": train.ll_from names no trained run (no checkpoint/LATEST there): give a run "
                         "folder written by f16race train");
  // The pilot flies with the throttle it learned with: its policy's, or the governor's alone.
  const TrainConfig pilot = read_run_config(from).config;
  if (pilot.loop.ll_throttle != cfg.loop.ll_throttle)
    throw io::InputError(from + ": train.ll_from's low level was trained with another train.ll_throttle than this "
                         "config's: use its value from " + from + "/config.yaml");
  if (pilot.loop.ll_pilot != cfg.loop.ll_pilot)
    throw io::InputError(from + ": train.ll_from's low level was trained with another train.ll_pilot than this "
                         "config's: use its value from " + from + "/config.yaml");
  const std::string path = from + "/checkpoint/" + name + "/ll.pt";
  const auto shapes = [this] {  // a load replaces tensors whole: a different network would just take their place
    std::vector<std::vector<std::int64_t>> out;
    for (const auto& p : ppo->net()->named_parameters()) out.push_back(p.value().sizes().vec());
    return out;
  };
  const auto before = shapes();
  bool fits = true;
  try {
    ppo->load(path);  // the networks, the observation statistics and the (unused) optimiser state
  } catch (const c10::Error&) {
    fits = false;
  }
  if (!fits || shapes() != before)
    throw io::InputError(path + ": train.ll_from's low level does not fit this config (observation sizes or the "
                         "ll: network differ): use the race: and ll: sections of " + from + "/config.yaml");
}

void Trainer::State::clear_for_fresh_start() {
  for (const auto& entry : fs::directory_iterator(run_dir)) {
    const std::string name = entry.path().filename().string();
    if (name != ".lock" && name != "config.yaml") fs::remove_all(entry.path());
  }
  fs::create_directories(fs::path(run_dir) / "checkpoint");
  fs::create_directories(fs::path(run_dir) / "pool");
  io::write_file_atomic(run_dir + "/checkpoint/LATEST", "");
}

void Trainer::State::group_sum(std::vector<double>& v) const {
  if (group != nullptr) group->allreduce_sum(v);
}
void Trainer::State::group_sum(std::vector<std::int64_t>& v) const {
  if (group != nullptr) group->allreduce_sum(v);
}

}  // namespace f16race::train
