#pragma once
// Private to lib/train: Trainer::State, everything one rank's trainer holds, shared by the files
// that each do one of its jobs:
//   trainer.cpp             start, resume and the update loop (Trainer's public side)
//   trainer_build.cpp       networks, env slice and random streams from the config
//   rollout.cpp             LL steps and HL decisions: actions, rewards, HL transitions
//   learner_updates.cpp     PPO and Expected SARSA updates from what the rollout gathered
//   self_play.cpp           matchups and the pool opponent
//   tail_ensemble.cpp       the HL-only tail's start and its members (train.hl_tail_members)
//   trainer_checkpoint.cpp  checkpoint folders: save, load, meta.yaml, LATEST
//   trainer_metrics.cpp     metrics rows: accumulated, written, cut back at a resume
#include <torch/torch.h>

#include <chrono>
#include <cstdint>
#include <fstream>
#include <memory>
#include <optional>
#include <sstream>
#include <string>
#include <vector>

#include "io/input_error.hpp"
#include "io/learning_curves.hpp"
#include "io/run_folder.hpp"
#include "race/race_env.hpp"
#include "random/random_stream.hpp"
#include "train/obs_views.hpp"
#include "train/policy_rows.hpp"
#include "train/snapshot_pool.hpp"
#include "train/trainer.hpp"

namespace f16race::train {

// Open high-level decisions of the learner team, one slot per env.
struct OpenHl {
  models::HlObs obs;          // fields [n_env, team_size, ...]
  torch::Tensor actions;      // [n_env, ts, 3] int64
  torch::Tensor reward;       // [n_env, ts] float32, accumulated since the decision
  torch::Tensor active;       // [n_env, ts] bool
  std::vector<std::uint8_t> open;  // [n_env]
};

// A checkpoint's files as rank 0 read them (trainer_checkpoint.cpp).
struct CheckpointFiles;

// train.hl_tail_members > 1 trains its members in one process (tail_ensemble.cpp): a group of
// ranks is refused, naming `source`.
void check_tail_members_in_one_process(const TrainConfig& cfg, int world, const std::string& source);

struct Trainer::State {
  // Declared first, so released last: no other process writes the folder while this one lives.
  std::unique_ptr<io::RunFolderLock> lock;
  // Data-parallel ranks (issue 18): null or size 1 for one process. Rank 0 writes the run folder.
  dist::Group* group = nullptr;
  int rank = 0, world = 1;
  TrainConfig cfg;
  std::string run_dir;
  std::string resolved_yaml;
  std::uint64_t hash = 0;
  std::unique_ptr<race::RaceEnv> env;
  std::unique_ptr<agents::PpoAgent> ppo, opp_ppo;
  std::unique_ptr<agents::EsAgent> es, opp_es;
  std::unique_ptr<agents::RolloutBuffer> buffer;
  PolicyRows ll_rows{2, 0}, hl_rows{2, 0};  // [n_env * n_agent] learner (0) and pool (1) rows
  at::Generator gen;
  RandomStream stream{1, 0xC0FFEE};
  // The HL-only tail's first update has begun (start_tail): a tail member's streams are switched,
  // an ensemble's members forked. Kept in trainer.pt only by runs with either.
  bool tail_started = false;
  int n_env = 0, n_agent = 0, ts = 0;  // n_env: this rank's envs
  int n_env_global = 0;                // race.n_env: the group's
  models::ObsDims dims;

  // Counters.
  std::int64_t env_steps = 0, ppo_updates = 0, es_updates = 0, hl_grad_steps = 0;
  std::int64_t rank_env_steps = 0;  // this rank's own, in this process (not checkpointed)
  int phase = 0;               // 0: low level learns, 1: high level learns
  int phase_updates = 0;       // updates done in the current phase
  std::int64_t opponent = -1;  // pool snapshot (its env_steps) the pool envs play, -1: none
  SnapshotPool pool{"", 0, false};  // set up by build()
  std::vector<int> side;       // [n_env] learner team
  // [n_env] who the opponent is: kVsSelf the current policy, kVsPool the pool snapshot,
  // kVsCenter the current low level with a center-line high level (pool.p_center_tail).
  std::vector<std::uint8_t> vs_pool;
  enum : std::uint8_t { kVsSelf = 0, kVsPool = 1, kVsCenter = 2 };

  // HL transitions.
  OpenHl open;
  std::vector<models::HlObs> done_obs, done_next;
  std::vector<torch::Tensor> done_actions, done_reward, done_flag, done_active, done_next_active;

  // Metrics accumulators since the last row.
  std::vector<double> ll_ret, hl_ret;  // [n_env * ts] running returns of learner aircraft
  double sum_ll_ret = 0, sum_hl_ret = 0, n_ret = 0, n_hl_ret = 0, sum_goal = 0, n_goal = 0, sum_vt = 0, n_vt = 0;
  double races = 0, wins = 0, finishes = 0, term[race::kNumCauses] = {};
  std::int64_t steps_at_row = 0;
  double wall_at_row = 0.0, wall_offset = 0.0;
  std::chrono::steady_clock::time_point t0 = std::chrono::steady_clock::now();
  agents::PpoStats last_ppo;
  agents::EsStats last_es;
  TimeBreakdown timing;
  NetworkWork work;
  std::string curves_problem;  // why the last curves.png could not be made (empty: it was)
  // When curves.png was last drawn (none yet: the first checkpoint draws it).
  std::optional<std::chrono::steady_clock::time_point> curves_drawn_at;
  // A draw under way (it holds its own copy of the folder's name) ends before the folder lock,
  // declared first, is released.
  io::BackgroundCurves curves;
  using Clock = std::chrono::steady_clock;
  static double since(Clock::time_point t) { return std::chrono::duration<double>(Clock::now() - t).count(); }

  double wall() const {
    return wall_offset + std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
  }
  bool writes() const { return rank == 0; }

  // --- trainer.cpp: the update loop.
  // One update (an LL phase's PPO update or an HL phase's ES update), the group's steps summed.
  void train_one_update(bool ll_phase);
  // After an update: the other level learns next once the phase is over, against a new opponent.
  void switch_phase_if_due(bool ll_phase);

  // --- trainer_build.cpp
  void build(bool fresh);
  void build_learners();  // agents, pool opponent, rollout buffer
  // train.ll_from: the named run's latest low level (weights and observation statistics).
  void load_frozen_low_level();
  // A run folder resumed before its first checkpoint: everything but config.yaml (and the lock)
  // removed, so the run starts again.
  void clear_for_fresh_start();
  // Sums over the ranks, in place (nothing for one process).
  void group_sum(std::vector<double>& v) const;
  void group_sum(std::vector<std::int64_t>& v) const;

  // --- rollout.cpp
  int learner_agent(int e, int j) const { return e * n_agent + side[e] * ts + j; }
  bool is_learner(int e, int agent) const { return agent / ts == side[e]; }
  // Which learner aircraft of env e count in an HL transition (docs/learning.md, "Elimination"):
  // the egoistic critics (es, es_d1) keep an eliminated aircraft in its own transitions to the
  // race's end (it is paid the team term; its bins have no effect); the team critics count the
  // aircraft alive at the decision and value the team's future through its living members.
  // At a race's end the env has already reset, so who was alive is read from `truncated`.
  torch::Tensor hl_members(int e, bool at_race_end = false) const;
  // Who flies each aircraft: 0 the learner's networks (its team, and both teams in self-play
  // envs), 1 the pool snapshot (the other team in pool envs); -1 where `only` is given and
  // its env's flag is down (an HL decision only for the envs that are due), and for the high
  // level of a center-line opponent (its rows keep the middle bin).
  std::vector<int> owners(const std::uint8_t* only = nullptr, bool high_level = false) const;
  // The learner team's aircraft, [n_env * ts]: the rollout buffer's columns (PPO's samples).
  torch::Tensor learner_index() const;
  models::LlObs ll_view(bool final_obs) const { return ll_obs_view(*env, final_obs); }
  models::HlObs hl_view(bool final_obs) const { return hl_obs_view(*env, final_obs); }
  void hl_decisions();
  void close_open(int env, bool done, const models::HlObs& next_rows, const torch::Tensor& next_active);
  void ll_step(bool learn);
  // Of ll_step: every aircraft's LL actions [n_env * n_agent, kActionDim]; `act` the learner's
  // policy output (empty under the autopilot).
  torch::Tensor ll_actions(bool learn, agents::PpoAction* act);
  // Of ll_step, after env->step: rewards, returns and race causes of the learner aircraft, and
  // (learning) their samples committed to the rollout buffer.
  void record_step(const torch::Tensor& learner, bool learn);
  // Of record_step: this step's rewards, ends and validity (the aircraft acted) of the learner
  // team's aircraft into the rollout buffer.
  void commit_samples(const torch::Tensor& learner);
  // Of ll_step: the races that ended, their results and HL transitions closed; new matchups.
  void end_races(const torch::Tensor& learner);

  // --- learner_updates.cpp
  void ppo_update();
  void es_update();

  // --- self_play.cpp
  void draw_matchup(int env);
  void snapshot_pool();
  void load_opponent();
  void load_pool_snapshot();  // the pool's `opponent` into opp_ppo, opp_es

  // --- tail_ensemble.cpp
  // The run has used its low level's share of the steps: only the high level learns from here
  // (train.hl_tail_share).
  bool in_hl_tail() const { return in_last_share(cfg.loop.hl_tail_share); }
  // In the tail with the low level frozen for good: the tail's matchups, and where its members'
  // streams begin (a run resumed inside an LL phase past the tail's share finishes that phase's
  // update first).
  bool in_frozen_tail() const { return in_hl_tail() && phase == 1; }
  // The run is a tail member (LoopConfig::tail_member) or forks some (train.hl_tail_members).
  bool has_tail_members() const { return cfg.loop.tail_member > 0 || cfg.loop.hl_tail_members > 1; }
  // The run is in the last `share` of its env steps (never, for a share of 0).
  bool in_last_share(double share) const {
    return share > 0.0 && static_cast<double>(env_steps) >= (1.0 - share) * static_cast<double>(cfg.loop.total_env_steps);
  }
  // At the first update of the HL-only tail. train.hl_tail_members K > 1: a checkpoint, then
  // fork_tail_members. A tail member m > 0: the env's track streams, the matchup stream, the
  // exploration generator and the ES minibatch order become member m's.
  void start_tail();
  // RUN/members/1..K-1 from the LATEST checkpoint: run folders of this config with tail_member m
  // (config.yaml, the checkpoint under its hash, the pool, metrics.csv), each made in a temporary
  // folder and renamed; a member folder that exists is kept (a resumed run forks once).
  void fork_tail_members();

  // --- trainer_checkpoint.cpp
  // The ranks' networks are the same bits (they take the same steps): checked at every
  // checkpoint, so a broken invariant stops the run instead of training diverged replicas.
  void check_replicas_agree();
  // `last`: the run's final checkpoint (budget reached, stopped, or --max-updates), which always
  // redraws the learning curves.
  void save_checkpoint(bool last);
  // This rank's trainer state as trainer.pt's bytes.
  std::string trainer_state_bytes();
  void load_checkpoint();
  // Of load_checkpoint, rank 0 (or the single process): the LATEST checkpoint's files, checked
  // against this run; the reason as an exception when they cannot be resumed from.
  void read_checkpoint_files(CheckpointFiles* files) const;
  // Of load_checkpoint, every rank: the networks and this rank's trainer state from its bytes;
  // the reason (naming the file) when they do not parse, "" when they do.
  std::string restore_checkpoint(const CheckpointFiles& files, const std::string& trainer_bytes);
  // Of load_checkpoint: the pool snapshot the checkpoint plays, back into opp_ppo and opp_es.
  void reload_opponent();
  // At a resume: checkpoint folders other than LATEST's (written, never committed) are removed.
  void remove_uncommitted_checkpoints() const;
  // Everything trainer.pt holds, in one list both adapters walk. The stream is passed as a plain
  // value: saved from stream.state(), restored by the caller. The wall clock is not in it (the
  // checkpoint's wall_s.txt), so trainer.pt's bytes depend only on the run.
  template <class V>
  void visit_checkpoint(V& v, std::uint64_t& stream_state);
  // Waits for the curves draw under way and keeps why it failed, if it did, for the summary.
  void collect_curves() {
    if (std::string problem = curves.wait(); !problem.empty()) curves_problem = problem;
  }
  // Starts a draw of the run's curves once the one under way has ended.
  void redraw_curves(std::chrono::steady_clock::time_point now) {
    collect_curves();
    curves_drawn_at = now;
    curves.start(run_dir);
  }

  // --- trainer_metrics.cpp
  MetricsRow make_row(const char* phase_name);
  void write_row(const MetricsRow& r);
  void truncate_metrics();
};

}  // namespace f16race::train
