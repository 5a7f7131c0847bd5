#pragma once
// The trained policy of a run folder written by `f16race train` (its newest checkpoint), for
// evaluation, replays and export. Everything that reads a run's policy goes through here, so a
// missing, corrupt or mismatched run is refused the same way everywhere.
#include <cstdint>
#include <memory>
#include <string>
#include <vector>

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
  // An ensemble's other high levels (load_ensemble_policy): the policy is greedy on the mean of
  // hl's and their action values. Empty for a run.
  std::vector<std::unique_ptr<agents::EsAgent>> hl_members;
};

// Loads the LATEST checkpoint of `run_dir`; a finished run with train.hl_tail_members
// K > 1 on the ensemble of its K tails (RUN and RUN/members/1..K-1, as load_ensemble_policy). Throws io::InputError naming the file and the
// fix when the folder is not a run, has no checkpoint, was written by another config.yaml
// (hash mismatch) or a checkpoint file is unreadable.
RunPolicy load_run_policy(const std::string& run_dir);

// The mean-Q ensemble of the high levels of several runs that share one low level (the same
// ll.pt bytes: e.g. high-level tails trained from one run's checkpoint): the first run's low level
// flies, and each decision is eps-greedy on the mean of the runs' action values, each critic on
// its own normalised observations. The name joins the folders' names with '+'. Throws
// io::InputError naming the run and the fix when the runs' low levels, variants or bins differ.
RunPolicy load_ensemble_policy(const std::vector<std::string>& run_dirs);

// The policy a tournament or replay entry names: a run folder, or folders joined by '+' (an
// ensemble, above) when no folder has that name.
RunPolicy load_policy_spec(const std::string& spec);

// Throws io::InputError naming `other`'s folder unless it was trained for the same race
// shapes (team size, observation sizes) and goal frame as `reference`, so their policies can
// share races.
void check_same_race_shape(const RunPolicy& reference, const RunPolicy& other);

// Writes policy p's greedy LL actions [n_env * n_agent, 3] for the aircraft in `rows` (ascending
// indices into env * n_agent + agent; the others untouched): its network's mean on those rows of
// `obs`, or, for a run trained with train.ll_pilot autopilot, AeroBench's waypoint autopilot
// flying each aircraft's goal lane. The one
// low-level act of the tournament and replay.
void greedy_ll_actions(const RunPolicy& p, const race::RaceEnv& env, const models::LlObs& obs,
                       const torch::Tensor& rows, at::Generator& gen, float* actions);

// train.ll_throttle governor: the throttle action (column 0 of `actions` [*, 3]) of the `n_rows`
// aircraft in `rows` (ascending indices; null: rows 0 .. n_rows - 1) set to full; the race's Mach
// governor caps it. A policy throttle leaves them untouched.
void apply_ll_throttle(const TrainConfig& config, const std::int64_t* rows, std::int64_t n_rows, float* actions);

// Writes policy p's HL bins [n_env * n_agent, 3] for the aircraft in `rows` (ascending indices as
// above), eps-greedy with `epsilon`. The one high-level act of the tournament and replay.
void policy_hl_bins(const RunPolicy& p, const models::HlObs& obs, const torch::Tensor& rows, double epsilon,
                    at::Generator& gen, std::int64_t* bins);

// The networks of `config` before any update (initial weights from `seed`), as the
// `untrained` tournament entry and for tests.
RunPolicy untrained_policy(const TrainConfig& config, std::uint64_t seed);

}  // namespace f16race::train
