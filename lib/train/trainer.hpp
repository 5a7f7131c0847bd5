#pragma once
// Bilevel self-play training (paper Eq. 5): alternating phases of low-level PPO updates under a
// fixed high-level policy and high-level Expected SARSA updates under a fixed low-level policy,
// against the current policy or a pool snapshot. Writes the run folder:
//   RUN/config.yaml          resolved configuration (its hash guards the checkpoints)
//   RUN/metrics.csv          one row per update
//   RUN/checkpoint/LATEST    name of the newest complete checkpoint folder
//   RUN/checkpoint/step_N/   ll.pt, hl.pt, trainer.pt (env, streams, counters), meta.yaml
//   RUN/pool/step_N/         self-play snapshots (ll.pt, hl.pt)
//   RUN/curves.png           learning curves from metrics.csv, redrawn at a checkpoint at most
//                            every 30 s and at the last one
//                            (curves.gp, curves_data.csv beside it)
// Data-parallel over a dist::Group (issue 18, docs/distributed.md): every rank steps its slice of
// race.n_env (global env ids, its own random streams), the learners' gradient steps and
// observation statistics are agreed across ranks (agents/replicas.hpp), and rank 0 alone writes
// the run folder; a checkpoint holds every rank's trainer state (trainer.pt for rank 0,
// trainer_rankN.pt for the others), gathered to rank 0.
#include <array>
#include <atomic>
#include <cmath>
#include <cstdint>
#include <exception>
#include <functional>
#include <memory>
#include <string>
#include <vector>

#include "race/race_env.hpp"
#include "random/random_stream.hpp"
#include "train/metrics_file.hpp"
#include "train/train_config.hpp"

namespace f16race::dist {
class Group;
}

namespace f16race::train {

// 2: HL reward scale, elimination rule and HL diagnostics (a format-1 run learned other targets).
// 3: the race snapshot no longer holds a copy of the previous actions beside their observation.
inline constexpr int kCheckpointFormat = 3;
// The oldest format whose networks (ll.pt, hl.pt) this build still loads to evaluate, replay or
// export: formats 2 and 3 differ only in the trainer's resume state.
inline constexpr int kOldestPolicyFormat = 2;
enum class CheckpointUse { resume, policy };

// Reads CHECKPOINT_DIR/meta.yaml and returns its env_steps; throws std::runtime_error (the caller
// adds the path) unless it has this build's format and was written under `expected_config_hash`.
std::int64_t check_checkpoint_meta(const std::string& checkpoint_dir, std::uint64_t expected_config_hash,
                                   CheckpointUse use = CheckpointUse::resume);

// The checkpoint folder RUN/checkpoint/LATEST names (surrounding whitespace ignored, so a file
// edited by hand reads the same everywhere); "" when LATEST is missing or empty.
std::string latest_checkpoint_name(const std::string& run_dir);

// The one-line reason of a failed checkpoint read, for a message that names the file and the fix:
// LibTorch's errors carry a C++ backtrace after their first line. Cut to 160 characters.
std::string checkpoint_error_reason(const std::exception& e);

// Self-play matchups, drawn per race from the trainer's own stream (deterministic per seed).
struct Matchup {
  int learner_side = 0;   // 0 blue, 1 red
  bool vs_pool = false;   // opponent is the current pool snapshot (else the current policy)
  bool vs_center = false; // opponent is the learner's low level under a center-line high level
};
// in_tail: the race starts in the HL-only tail, where pool.p_center_tail of them are against the center line.
Matchup draw_matchup(RandomStream& stream, const PoolConfig& pool, bool pool_available, bool in_tail = false);
// Which pool snapshot the next phase plays: uniform over the n stored ones.
std::size_t draw_pool_entry(RandomStream& stream, std::size_t n);

// Where the wall time of run() went [s].
struct TimeBreakdown {
  double env = 0.0;        // race env step: simulator, race logic, observations
  double inference = 0.0;  // policy forward passes in rollouts (LL and HL, learner and pool)
  double ppo = 0.0;        // PPO updates (incl. GAE)
  double es = 0.0;         // Expected SARSA updates
  // Of ppo and es: their steps' wall time beyond an even split of each step's concurrent chunks over
  // the threads (agents::run_chunks): what a slower core and the fork/join cost.
  double ppo_chunk_wait = 0.0, es_chunk_wait = 0.0;
  double io = 0.0;         // metrics, pool snapshots, checkpoints
  // The wait for the run's last learning-curves figure at its final checkpoint (gnuplot, ~0.1 s):
  // once per run whatever its length, so not part of the per-update rate `bench train` reports.
  double run_end = 0.0;
  double other = 0.0;      // bookkeeping between the above
  double total = 0.0;
  double per_update_loop() const { return total - run_end; }  // every update's share of the wall time
};

// Aircraft rows through each network and the calls they came in (rows / calls = the mean batch),
// counted by this process: `bench train` prices them at measured per-sample costs (its floor).
struct NetworkWork {
  std::int64_t ll_forward_rows = 0, ll_forward_calls = 0;  // LL no-grad: rollout actions, PPO bootstrap values
  std::int64_t ll_train_rows = 0, ll_train_calls = 0;      // PPO minibatch chunks, forward+backward
  std::int64_t ll_train_steps = 0;                          // PPO minibatch steps (their chunks run concurrently)
  std::int64_t hl_forward_rows = 0, hl_forward_calls = 0;  // HL no-grad: decisions, ES targets and diagnostics
  std::int64_t hl_train_rows = 0, hl_train_calls = 0;      // ES minibatch chunks, forward+backward
  std::int64_t hl_train_steps = 0;                          // ES gradient steps (their chunks run concurrently)
  // Other aircraft alive, summed over the rows above: the attention core skips the dead, so the
  // floor prices each part at its rows' alive share (alive / (rows * n_other)).
  std::int64_t ll_forward_alive = 0, ll_train_alive = 0, hl_forward_alive = 0, hl_train_alive = 0;
};

struct TrainSummary {
  TimeBreakdown time;
  NetworkWork work;
  std::int64_t updates = 0;
  std::int64_t env_steps = 0;
  std::int64_t hl_grad_steps = 0;  // ES gradient steps of the whole run
  std::string curves_problem;      // why RUN/curves.png was not drawn at the last checkpoint, if not
  bool interrupted = false;
  double communication_s = 0.0;  // inside the group's collectives (also counted in `time`'s parts)
  std::int64_t rank_env_steps = 0;  // LL steps of this rank's envs in this run() (env_steps: the group's, in all)
  std::vector<MetricsRow> rows;  // every row written by this process (rank 0: the group's)
};

class Trainer {
 public:
  // Fresh run: creates `run_dir` and locks it for this object's lifetime; refused if the folder
  // holds anything of a run (io::run_data_in) or another process holds its lock. With a group of
  // more than one rank, this is one rank of it: only rank 0 touches `run_dir`, every rank must
  // be given the same config, and race.n_env must split evenly over the ranks.
  Trainer(const TrainConfig& config, const std::string& run_dir, dist::Group* group = nullptr);
  // Resume: reads RUN/config.yaml and the LATEST checkpoint; refuses a corrupt or mismatched one.
  // With a group, rank 0 reads them and sends each rank its part; the group must have the size
  // the checkpoint was written by.
  static std::unique_ptr<Trainer> resume(const std::string& run_dir, dist::Group* group = nullptr);
  ~Trainer();

  // Trains until the step budget, `stop` becoming true (checked after every update; then a
  // checkpoint is written), or `max_updates` more updates (<0: no limit; for tests).
  TrainSummary run(const std::atomic<bool>* stop = nullptr, std::int64_t max_updates = -1,
                   const std::function<void(const MetricsRow&)>& on_row = {});

  const TrainConfig& config() const;
  std::int64_t updates() const;
  // Learner weights, for tests that compare runs.
  std::vector<float> ll_parameters() const;
  std::vector<float> hl_parameters() const;

 private:
  struct State;
  explicit Trainer(std::unique_ptr<State> state);
  std::unique_ptr<State> s_;
};

// RUN/members/M: the run folder of tail member M (train.hl_tail_members), the one spelling of it.
std::string member_dir(const std::string& run_dir, int m);

// "" when every tail member of a run of train.hl_tail_members K (RUN/members/1..K-1) has a
// checkpoint at its budget; otherwise one line naming the first that has not and the fix
// (`train --resume RUN`). Reads each member's config.yaml and checkpoint meta.yaml only. Throws
// io::InputError naming the member's meta.yaml when it cannot be read. The one definition of
// "the ensemble is complete" for the study and for loading the run's policy.
std::string unfinished_tail_member(const std::string& run_dir, const TrainConfig& config);

// train.hl_tail_members K > 1: trains the run's tail members RUN/members/1..K-1 (forked at its
// tail's first update) to the end, one after the other, each resumed from its own LATEST
// checkpoint (a member already at the end returns at once); stops after a member whose run was
// interrupted by `stop`. `on_row(m, row)` for every metrics row of member m. Throws
// io::InputError naming a member folder that is missing.
std::vector<TrainSummary> train_tail_members(const std::string& run_dir, const std::atomic<bool>* stop = nullptr,
                                             const std::function<void(int, const MetricsRow&)>& on_row = {});

}  // namespace f16race::train
