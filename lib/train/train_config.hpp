#pragma once
// Everything `f16race train` needs, as plain structs with defaults, read from one YAML file
// (sections race, ll, hl, train, pool) and validated with the file and key path in every error.
#include <cstdint>
#include <string>
#include <vector>

#include "agents/expected_sarsa.hpp"
#include "agents/ppo.hpp"
#include "race/race_config.hpp"
#include "race/scripted_pilot.hpp"

namespace YAML {
class Node;
}

namespace f16race::train {

// Who flies the low level: the PPO policy (the paper), or AeroBench's waypoint autopilot flying
// the lane of each aircraft's HL goal at a held airspeed, so that only the high level learns and
// what it learns is measured without the low level's own learning in the way.
// ppo: the network's action; autopilot: AeroBench's waypoint autopilot toward the goal, no network.
enum class LowLevelPilot { kPpo, kAutopilot };
// Who sets the low level's throttle: the policy (its first action, the paper's), or the race's
// Mach governor alone: full throttle, capped by race.mach_governor, as the autopilot flies with its
// set point above the cap. The policy's throttle output is then not used.
enum class LowLevelThrottle { kPolicy, kGovernor };

struct LoopConfig {
  // LL steps summed over envs (paper: 1 M per env x 1024 envs); twice 5.25 M since the pilot out-flew
  // its 5.25 M self on the autopilot's line (docs/results.md, "Pilot designs against the classic one").
  std::int64_t total_env_steps = 10500000;
  int ll_phase_updates = 8;               // PPO updates per low-level phase (HL frozen)
  int hl_phase_updates = 2;               // ES updates per high-level phase (LL frozen)
  int checkpoint_every_updates = 20;      // also at the end and on Ctrl-C
  double hl_epsilon_eval = 0.0;           // eps of the opponent's HL when it is a pool snapshot
  int log_every_updates = 1;              // plain log line cadence when stdout is not a terminal
  LowLevelPilot ll_pilot = LowLevelPilot::kPpo;  // autopilot: no LL phase, every update is an ES update
  double autopilot_airspeed_ftps = 0.0;          // its set point; 0: race.start_speed_ftps, as the `autopilot` entry
  LowLevelThrottle ll_throttle = LowLevelThrottle::kGovernor;
  // Share of total_env_steps at the end of a run in which the LL is frozen and only the HL learns
  // (every update an ES update): the bilevel problem's outer level against the final inner one.
  double hl_tail_share = 0.3333333333;  // the last third
  // Not a config key: > 0 in the run folders RUN/members/m that a run with hl_tail_members > 1
  // forks (their config.yaml lists it, read by read_run_config only). From the first update of the
  // HL-only tail on, such a run draws from member m's random streams (new races' tracks and
  // starts, matchups, exploration, ES minibatch order): tails of one low level, each an independent
  // draw (docs/learning.md, "An ensemble of tails"). 0: the run's own streams throughout.
  int tail_member = 0;
  // K > 1: the run's policy is an ensemble of K HL-only tails of its final low level, greedy on the
  // mean of their critics' action values. The run itself is tail 0; at its tail's first update it
  // writes a checkpoint and forks RUN/members/1..K-1 (run folders of this config with
  // tail_member m), which `train` trains after it, each as long as the run's own tail.
  int hl_tail_members = 3;
  // A trained run folder whose low level this run flies, frozen, from its first update: only the
  // high level learns, every update an ES update. High-level rules are then compared on one pilot
  // that races (the Fig. 3 study); the run copies the weights into its own checkpoints, so it
  // never reads the folder again after it started. Empty: the run learns its own low level.
  std::string ll_from;
  // An HL phase that follows an HL phase (the HL-only tail, train.ll_from, train.ll_pilot
  // autopilot) changes only the pool opponent: true keeps the learner's decisions still open
  // across it, so they are learned from; false drops them, as at every phase switch (an LL phase
  // between two HL phases leaves them stale).
  bool keep_hl_decisions = false;
};

struct PoolConfig {
  double p_self_play = 0.5;        // paper: current policy or a past checkpoint with equal odds
  // Share of the HL-only tail's races (train.hl_tail_share; drawn first) against a center-line
  // control: the learner's own low level with every opponent's high level fixed at the middle
  // bin, the `@center` entry of a tournament. With the low level frozen, the high level then
  // learns to beat the formation its final low level flies (docs/learning.md, "The center line
  // in the tail"). The bilevel part before the tail has the paper's pool only.
  double p_center_tail = 0.25;
  int snapshot_every_updates = 40; // PPO+ES updates between pool snapshots
  int max_snapshots = 20;          // oldest snapshots are removed beyond this
  bool randomize_sides = true;     // learner plays blue or red at random per race
};

// The trainer's HL defaults: reward scale and C51 support 0, i.e. derived from the race by
// resolve_hl_scales; 8 epochs x 8 minibatches per ES update (64 gradient steps on each batch):
// measured on the default config over 220 updates, the loss on each new batch before its update
// fell to 3.87 (1 x 1, i.e. ~ln 51: no learning), 2.69 (4 x 4), 2.36 (8 x 8), see docs/learning.md.
// The main job's high level: es_d2, 2 HL transitions per env per update, each gradient step's
// teams in 2 concurrent chunks.
inline agents::EsConfig auto_scaled_es_config() {
  agents::EsConfig c;
  c.variant = agents::EsVariant::kEsD2;
  c.v_min = c.v_max = 0.0;
  c.reward_scale = 0.0;
  c.n_steps_per_update = 2;
  c.n_epochs = 8;
  c.n_minibatches = 8;
  c.minibatch_chunks = 2;
  return c;
}

// The main job's low level: calm initial exploration (std 0.37), as random full-stick pilots
// leave the tube in seconds.
inline agents::PpoConfig recipe_ppo_config() {
  agents::PpoConfig c;
  c.net.init_log_std = -1.0;
  return c;
}

// The defaults are the main job's (configs/default.yaml lists them; a test holds the two equal):
// a config that leaves a key out gets the value here. Other configs are overlays on them.
struct TrainConfig {
  race::RaceConfig race;
  agents::PpoConfig ll = recipe_ppo_config();
  agents::EsConfig hl = auto_scaled_es_config();
  LoopConfig loop;
  PoolConfig pool;
  std::uint64_t seed = 1;
};

// The low level of a train.ll_pilot autopilot run, in training, tournaments and replays alike:
// AeroBench's waypoint autopilot flying each aircraft's goal lane at the configured airspeed.
race::AutopilotPilotConfig goal_lane_autopilot(const TrainConfig& config);


// Who wrote a config: a user (a file and --set), or train (a run folder's config.yaml, which may
// also list the internal train.tail_member).
enum class ConfigOrigin { kUser, kRunFolder };

// Reads `root` (already loaded, --set overrides applied). Unknown top-level sections
// or keys, wrong types and out-of-range values throw io::ConfigError naming `source` and the key;
// and a race.seed other than seed. `root` is first brought to the current version in place
// (config_versions::migrate: a run folder's file without config_version is version 1).
TrainConfig read_train_config(const YAML::Node& root, const std::string& source,
                              ConfigOrigin origin = ConfigOrigin::kUser);

// Fills the HL scales left at 0 ("auto") in `config` from the race (docs/learning.md, "HL
// reward scale and C51 support"): hl.reward_scale = dt_ll / dt_hl, so an interval's reward is
// its mean per-step reward, |r| <= 1.1 (team term 1, ego term at most a tenth of it); and, when
// hl.v_min and hl.v_max are both 0, the support +-1.1 sum_{k<H} gamma^k with H the most HL
// decisions a race can hold, ceil(time_limit / dt_hl). Called by read_train_config.
void resolve_hl_scales(TrainConfig* config);
// Bound of |HL reward| per interval after scaling, and of the discounted HL return of a race.
double hl_interval_reward_bound(const TrainConfig& config);
double hl_return_bound(const TrainConfig& config);

// The resolved configuration as YAML (every key, defaults included): written to the run folder,
// and hashed to refuse a checkpoint from a different configuration.
std::string train_config_yaml(const TrainConfig& config);
std::uint64_t config_hash(const std::string& resolved_yaml);

// RUN/config.yaml of a training run from one read: parsed, its text, and the hash of that text
// which the run's checkpoints record. Throws io::InputError naming the folder when it is not
// a run, io::ConfigError naming the file and key when the file is malformed.
struct RunConfig {
  TrainConfig config;
  std::string yaml;
  std::uint64_t hash = 0;
};
RunConfig read_run_config(const std::string& run_dir);

}  // namespace f16race::train
