// Trainer's public side: a run started or resumed in its folder, and the update loop that
// alternates the two levels' phases, writes the metrics rows and the checkpoints. The State's
// other jobs are in the files trainer_state.hpp lists.
#include "train/trainer.hpp"

#include <torch/torch.h>

#include <filesystem>
#include <functional>
#include <stdexcept>
#include <string>
#include <vector>

#include "dist/process_group.hpp"
#include "io/atomic_file.hpp"
#include "io/run_folder.hpp"
#include "io/stale_temporaries.hpp"
#include "io/yaml_config.hpp"
#include "train/run_numerics.hpp"
#include "train/trainer_state.hpp"

namespace f16race::train {

namespace fs = std::filesystem;

namespace {

std::vector<float> flat_parameters(const torch::nn::Module& m) {
  std::vector<float> out;
  for (const auto& p : m.parameters()) {
    const auto c = p.detach().contiguous().to(torch::kFloat32);
    out.insert(out.end(), c.data_ptr<float>(), c.data_ptr<float>() + c.numel());
  }
  return out;
}

// Takes the run folder's lock, then removes what killed writers left in it: temporaries of
// files, figures and pool snapshots (uncommitted checkpoint folders go at the resume).
std::unique_ptr<io::RunFolderLock> own_run_folder(const std::string& run_dir) {
  auto lock = std::make_unique<io::RunFolderLock>(run_dir);
  for (const char* sub : {"", "checkpoint", "pool"}) io::remove_stale_temporaries((fs::path(run_dir) / sub).string());
  return lock;
}

// Removes `run_dir` if it holds nothing but the lock's file (a start that failed before writing).
void remove_if_only_lock(const std::string& run_dir) {
  std::error_code ec;
  for (const fs::directory_entry& entry : fs::directory_iterator(run_dir, ec))
    if (entry.path().filename() != ".lock") return;
  if (ec) return;
  fs::remove(fs::path(run_dir) / ".lock", ec);
  fs::remove(run_dir, ec);
}
}  // namespace

Trainer::Trainer(std::unique_ptr<State> state) : s_(std::move(state)) {}
Trainer::~Trainer() = default;

Trainer::Trainer(const TrainConfig& config, const std::string& run_dir, dist::Group* group)
    : s_(std::make_unique<State>()) {
  s_->cfg = config;
  s_->run_dir = run_dir;
  if (group != nullptr && group->size() > 1) {
    s_->group = group;
    s_->rank = group->rank();
    s_->world = group->size();
  }
  check_tail_members_in_one_process(config, s_->world, "the config");
  if (!s_->writes()) {  // another rank: the run folder is rank 0's
    s_->resolved_yaml = train_config_yaml(config);
    s_->hash = config_hash(s_->resolved_yaml);
    s_->build(true);
    s_->snapshot_pool();
    s_->load_opponent();
    return;
  }
  std::error_code ec;
  const bool folder_is_new = !fs::exists(run_dir, ec);
  s_->lock = own_run_folder(run_dir);
  // Anything in the folder may be a run whose LATEST was lost: never write over it.
  if (const std::vector<std::string> data = io::run_data_in(run_dir); !data.empty()) {
    std::string names;
    for (const std::string& n : data) names += (names.empty() ? "" : ", ") + n;
    throw io::InputError(run_dir + " already holds a run (" + names + "): continue it with --resume " + run_dir +
                             ", move it aside with --overwrite, or choose another --run folder");
  }
  s_->resolved_yaml = train_config_yaml(config);
  s_->hash = config_hash(s_->resolved_yaml);
  try {
    s_->build(true);  // a config the run cannot be built from leaves the folder as it was
  } catch (...) {
    if (folder_is_new) {  // ... which, for a folder the lock created, is no folder at all
      s_->lock.reset();
      remove_if_only_lock(run_dir);
    }
    throw;
  }
  // config.yaml first, then an empty LATEST (no checkpoint is durable yet): a run stopped anywhere
  // in between resumes afresh, while a missing LATEST beside checkpoint folders is a lost pointer.
  fs::create_directories(fs::path(run_dir) / "checkpoint");
  fs::create_directories(fs::path(run_dir) / "pool");
  s_->lock->claim();  // from here on the folder is this run's
  io::write_file_atomic(run_dir + "/config.yaml", s_->resolved_yaml);
  io::write_file_atomic(run_dir + "/checkpoint/LATEST", "");
  // The untrained policy is the first pool snapshot, so pool matches exist from the start.
  s_->snapshot_pool();
  s_->load_opponent();
}

namespace {
// Rank 0's (or the single process's) reading of a run folder to resume: its config, and whether
// it has a checkpoint. A run killed before its first checkpoint has none and starts afresh.
RunConfig read_run_to_resume(const std::string& run_dir, bool* fresh) {
  if (!fs::is_directory(run_dir))
    throw io::InputError(run_dir + ": no such run folder to resume (a run stopped before it made its folder has "
                                   "nothing to resume: start it with f16race train --config CONFIG --run " + run_dir + ")");
  if (io::run_data_in(run_dir).empty())
    throw io::InputError(run_dir + ": holds no run yet (stopped before its config was written): start it with "
                                   "f16race train --config CONFIG --run " + run_dir);
  RunConfig run = read_run_config(run_dir);
  *fresh = false;
  if (!latest_checkpoint_name(run_dir).empty()) {
    check_resume_numerics(run_dir);  // a run goes on in the mode it trained in
    return run;
  }
  // An empty LATEST, as a new run writes it: no checkpoint is durable yet (a folder beside it is
  // one whose LATEST was never written), so the run starts afresh.
  if (fs::exists(fs::path(run_dir) / "checkpoint" / "LATEST")) {
    *fresh = true;
    return run;
  }
  // No LATEST at all: lost, unless no checkpoint folder exists (a run from before the empty
  // LATEST, stopped before its first checkpoint). Folders beside a lost LATEST are refused,
  // named, and kept.
  std::string folders;
  std::error_code ec;
  for (const auto& entry : fs::directory_iterator(fs::path(run_dir) / "checkpoint", ec))
    if (entry.is_directory(ec)) folders += (folders.empty() ? "" : ", ") + entry.path().filename().string();
  if (folders.empty()) {
    *fresh = true;
    return run;
  }
  throw io::InputError(run_dir + ": no checkpoint to resume from (checkpoint/LATEST missing or empty) beside "
                       "checkpoint folder(s) " + folders + ": write the name of the one to resume into " + run_dir +
                       "/checkpoint/LATEST, or start afresh with --overwrite (the old run is kept aside)");
}
}  // namespace

std::unique_ptr<Trainer> Trainer::resume(const std::string& run_dir, dist::Group* group) {
  auto st = std::make_unique<State>();
  if (group != nullptr && group->size() > 1) {
    st->group = group;
    st->rank = group->rank();
    st->world = group->size();
  }
  RunConfig run;
  bool fresh = false;
  if (st->group == nullptr) {
    if (fs::is_directory(run_dir)) st->lock = own_run_folder(run_dir);
    run = read_run_to_resume(run_dir, &fresh);
  } else {
    // Rank 0 reads the run's config and sends it: the other ranks may be on hosts without the
    // folder. A problem on rank 0 is every rank's one line.
    std::string problem;
    if (st->writes()) {
      try {
        if (fs::is_directory(run_dir)) st->lock = own_run_folder(run_dir);
        run = read_run_to_resume(run_dir, &fresh);
      } catch (const std::exception& e) {
        problem = e.what();
      }
    }
    group->broadcast_bytes(problem);
    if (!problem.empty()) throw io::InputError(problem);
    std::string yaml = run.yaml, fresh_flag = fresh ? "1" : "0";
    group->broadcast_bytes(yaml);
    group->broadcast_bytes(fresh_flag);
    fresh = fresh_flag == "1";
    if (!st->writes()) {
      run.yaml = yaml;
      const std::string source = run_dir + "/config.yaml (from rank 0)";
      run.config = read_train_config(io::parse_yaml_text(run.yaml, source), source, ConfigOrigin::kRunFolder);
      run.hash = config_hash(run.yaml);
    }
  }
  check_tail_members_in_one_process(run.config, st->world, run_dir + "/config.yaml");
  st->cfg = run.config;
  st->run_dir = run_dir;
  st->resolved_yaml = std::move(run.yaml);
  st->hash = run.hash;
  if (st->lock) st->lock->claim();  // every refusal is behind: this process writes the run
  if (fresh) {
    // Nothing durable yet: what the killed start left (a first pool snapshot, metrics rows) goes,
    // and the run begins again from its config, as `train --run` would have.
    if (st->writes()) st->clear_for_fresh_start();
    st->build(true);
    st->snapshot_pool();
    st->load_opponent();
  } else {
    st->build(false);
    st->load_checkpoint();
  }
  return std::unique_ptr<Trainer>(new Trainer(std::move(st)));
}

const TrainConfig& Trainer::config() const { return s_->cfg; }
std::int64_t Trainer::updates() const { return s_->ppo_updates + s_->es_updates; }
std::vector<float> Trainer::ll_parameters() const { return flat_parameters(*s_->ppo->net()); }
std::vector<float> Trainer::hl_parameters() const { return flat_parameters(*s_->es->critic()); }

void Trainer::State::train_one_update(bool ll_phase) {
  const std::int64_t steps_before = env_steps;
  if (ll_phase) {
    for (std::int64_t k = 0; k < cfg.ll.n_steps; ++k) ll_step(true);
    ppo_update();
  } else {
    // Each rank fills its own share of an ES batch (a group's ranks may step different numbers of
    // steps in an HL phase: no collective per step) and the group sums its steps after the update.
    const std::int64_t hl_batch = static_cast<std::int64_t>(n_env) * cfg.hl.n_steps_per_update;
    while (static_cast<std::int64_t>(done_obs.size()) < hl_batch) ll_step(false);
    es_update();
  }
  if (group != nullptr) {
    std::vector<std::int64_t> stepped{env_steps - steps_before};
    group_sum(stepped);
    env_steps = steps_before + stepped[0];
  }
}

void Trainer::State::switch_phase_if_due(bool ll_phase) {
  // Phase switch: the other level learns next; a new pool opponent for the new phase.
  const int phase_len = ll_phase ? cfg.loop.ll_phase_updates : cfg.loop.hl_phase_updates;
  // In the HL-only tail (train.hl_tail_share) an LL phase ends at once and never comes back.
  const bool hl_only =
      cfg.loop.ll_pilot == LowLevelPilot::kAutopilot || !cfg.loop.ll_from.empty() || in_hl_tail();
  if ((phase_updates >= phase_len || (hl_only && phase == 0)) && cfg.loop.hl_phase_updates > 0) {
    // With only the high level learning its phase repeats, each time against a newly drawn pool
    // opponent.
    phase = hl_only ? 1 : 1 - phase;
    phase_updates = 0;
    // Decisions of the old phase are not learned from, unless only the opponent changes.
    const bool hl_again = !ll_phase && phase == 1;
    if (!(hl_again && cfg.loop.keep_hl_decisions))
      for (int e = 0; e < n_env; ++e) open.open[e] = 0;
    load_opponent();
    for (int e = 0; e < n_env; ++e)
      if (opponent < 0 && vs_pool[e] == kVsPool) vs_pool[e] = kVsSelf;
  }
}

TrainSummary Trainer::run(const std::atomic<bool>* stop, std::int64_t max_updates,
                          const std::function<void(const MetricsRow&)>& on_row) {
  State& s = *s_;
  TrainSummary summary;
  s.timing = TimeBreakdown{};
  const auto t_run = State::Clock::now();
  std::int64_t done_here = 0;
  const double comm_at_start = s.group != nullptr ? s.group->collective_seconds() : 0.0;
  const std::int64_t rank_steps_at_start = s.rank_env_steps;
  while (s.env_steps < s.cfg.loop.total_env_steps) {
    if (max_updates >= 0 && done_here >= max_updates) break;
    if (s.has_tail_members() && !s.tail_started && s.in_frozen_tail()) s.start_tail();
    const bool ll_phase = s.phase == 0 || s.cfg.loop.hl_phase_updates == 0;
    s.train_one_update(ll_phase);
    ++done_here;
    ++s.phase_updates;
    const auto t_io = State::Clock::now();
    const MetricsRow row = s.make_row(ll_phase ? "ll" : "hl");
    s.write_row(row);
    summary.rows.push_back(row);
    if (on_row) on_row(row);
    const std::int64_t upd = s.ppo_updates + s.es_updates;
    if (upd % s.cfg.pool.snapshot_every_updates == 0) s.snapshot_pool();
    s.timing.io += State::since(t_io);
    s.switch_phase_if_due(ll_phase);
    std::vector<std::int64_t> stop_votes{stop != nullptr && stop->load() ? 1 : 0};
    s.group_sum(stop_votes);  // a stop seen by any rank stops the group after the same update
    const bool stopping = stop_votes[0] > 0;
    const bool last =
        stopping || s.env_steps >= s.cfg.loop.total_env_steps || (max_updates >= 0 && done_here >= max_updates);
    if (last || upd % s.cfg.loop.checkpoint_every_updates == 0) {
      const auto t_ck = State::Clock::now();
      s.save_checkpoint(last);
      s.timing.io += State::since(t_ck);
    }
    if (last) {  // the run's last figure, started by its last checkpoint: done before the run returns
      const auto t_end = State::Clock::now();
      s.collect_curves();
      s.timing.run_end += State::since(t_end);
    }
    if (stopping) {
      summary.interrupted = true;
      break;
    }
  }
  summary.updates = s.ppo_updates + s.es_updates;
  summary.env_steps = s.env_steps;
  summary.hl_grad_steps = s.hl_grad_steps;
  summary.curves_problem = s.curves_problem;
  summary.rank_env_steps = s.rank_env_steps - rank_steps_at_start;
  summary.communication_s = s.group != nullptr ? s.group->collective_seconds() - comm_at_start : 0.0;
  s.timing.total = State::since(t_run);
  s.timing.other = s.timing.total - s.timing.env - s.timing.inference - s.timing.ppo - s.timing.es - s.timing.io -
                   s.timing.run_end;
  summary.time = s.timing;
  summary.work = s.work;
  return summary;
}

}  // namespace f16race::train
