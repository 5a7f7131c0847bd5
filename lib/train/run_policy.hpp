#pragma once
// The trained policy of a run folder written by `f16race train` (its newest checkpoint), for
// evaluation, replays and export. Everything that reads a run's policy goes through here, so a
// missing, corrupt or mismatched run is refused the same way everywhere.
#include <cstdint>
#include <memory>
#include <string>

#include "agents/expected_sarsa.hpp"
#include "agents/ppo.hpp"
#include "models/obs.hpp"
#include "race/race_env.hpp"
#include "train/train_config.hpp"

namespace f16race::train {

struct RunPolicy {
  std::string name;            // the run folder's name, or "untrained"
  std::string run_dir;         // empty for the untrained policy
  std::string checkpoint_dir;  // RUN/checkpoint/<LATEST>; empty for the untrained policy
  std::int64_t env_steps = 0;  // training steps behind the checkpoint (meta.yaml)
  TrainConfig config;          // as trained; ll.net.dims and hl.dims filled in
  models::ObsDims dims;
  std::unique_ptr<agents::PpoAgent> ll;
  std::unique_ptr<agents::EsAgent> hl;
};

// Loads the LATEST checkpoint of `run_dir`; a run trained with train.hl_average_share acts on its
// high level's weight average (EsAgent::act_with_average). Throws io::InputError naming the file and the
// fix when the folder is not a run, has no checkpoint, was written by another config.yaml
// (hash mismatch) or a checkpoint file is unreadable.
RunPolicy load_run_policy(const std::string& run_dir);

// Throws io::InputError naming `other`'s folder unless it was trained for the same race
// shapes (team size, observation sizes) and goal frame as `reference`, so their policies can
// share races.
void check_same_race_shape(const RunPolicy& reference, const RunPolicy& other);

// Writes policy p's greedy LL actions [n_env * n_agent, 3] for the aircraft in `rows` (ascending
// indices into env * n_agent + agent; the others untouched): its network's mean on those rows of
// `obs`, or, for a run trained with train.ll_pilot autopilot, AeroBench's waypoint autopilot
// flying each aircraft's goal lane. The one low-level act of the tournament and replay.
void greedy_ll_actions(const RunPolicy& p, const race::RaceEnv& env, const models::LlObs& obs,
                       const torch::Tensor& rows, at::Generator& gen, float* actions);

// Writes policy p's HL bins [n_env * n_agent, 3] for the aircraft in `rows` (ascending indices as
// above), eps-greedy with `epsilon`. A run trained with hl.lateral: team takes one lane per team
// (aircraft i's team is i / team_size), so the rows go in with their teams. The one high-level act
// of the tournament and replay.
void policy_hl_bins(const RunPolicy& p, const models::HlObs& obs, const torch::Tensor& rows, double epsilon,
                    at::Generator& gen, std::int64_t* bins);

// The networks of `config` before any update (initial weights from `seed`), as the
// `untrained` tournament entry and for tests.
RunPolicy untrained_policy(const TrainConfig& config, std::uint64_t seed);

}  // namespace f16race::train
