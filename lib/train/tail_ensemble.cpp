// The HL-only tail's ensemble (train.hl_tail_members): the run's fork of its members at the
// tail's first update, a member's switch to its own streams, and the members' training after the
// run.
#include "train/tail_ensemble.hpp"

#include <filesystem>
#include <string>
#include <vector>

#include "io/atomic_file.hpp"
#include "train/trainer_state.hpp"

namespace f16race::train {

namespace fs = std::filesystem;

void check_tail_members_in_one_process(const TrainConfig& cfg, int world, const std::string& source) {
  if (cfg.loop.hl_tail_members > 1 && world > 1)
    throw io::InputError(source + ": train.hl_tail_members = " + std::to_string(cfg.loop.hl_tail_members) +
                         " trains its tail members in one process, not over a group of ranks; train without "
                         "launch, or with train.hl_tail_members 1");
}

void Trainer::State::start_tail() {
  // The members start from the state before any of the tail's draws, with tail_started unset.
  if (cfg.loop.hl_tail_members > 1) {
    save_checkpoint(false);
    if (writes()) fork_tail_members();
  }
  if (cfg.loop.tail_member > 0) {
    const std::uint64_t m = static_cast<std::uint64_t>(cfg.loop.tail_member);
    env->reseed_streams(m);
    stream = RandomStream(cfg.seed, 0xC0FFEE + static_cast<std::uint64_t>(rank) + (m << 32));
    gen.set_current_seed(cfg.seed * 7919 + 3 + static_cast<std::uint64_t>(rank) * 1000003 + m * 0x9E3779B97F4A7C15ULL);
    es->minibatch_generator().set_current_seed(cfg.hl.seed + m * 0x9E3779B97F4A7C15ULL);
  }
  tail_started = true;
}

void Trainer::State::fork_tail_members() {
  const fs::path members = fs::path(run_dir) / "members";
  const std::string ck = latest_checkpoint_name(run_dir);
  const std::string meta = io::read_file((fs::path(run_dir) / "checkpoint" / ck / "meta.yaml").string());
  for (int m = 1; m < cfg.loop.hl_tail_members; ++m) {
    const fs::path dir = members / std::to_string(m);
    if (fs::exists(dir)) continue;
    const fs::path tmp = members / ("." + std::to_string(m) + ".tmp");
    fs::remove_all(tmp);
    fs::create_directories(tmp / "checkpoint");
    // The member's config is this run's as a single tail drawn from member m's streams.
    TrainConfig member = cfg;
    member.loop.tail_member = m;
    member.loop.hl_tail_members = 1;
    const std::string yaml = train_config_yaml(member);
    io::write_file_atomic((tmp / "config.yaml").string(), yaml);
    fs::copy(fs::path(run_dir) / "checkpoint" / ck, tmp / "checkpoint" / ck, fs::copy_options::recursive);
    const std::string key = "config_hash: ";
    const std::size_t at = meta.find(key), end = meta.find('\n', at);
    io::write_file_atomic((tmp / "checkpoint" / ck / "meta.yaml").string(),
                          meta.substr(0, at + key.size()) + std::to_string(config_hash(yaml)) + meta.substr(end));
    io::write_file_atomic((tmp / "checkpoint" / "LATEST").string(), ck);
    fs::copy(fs::path(run_dir) / "pool", tmp / "pool", fs::copy_options::recursive);
    fs::copy_file(fs::path(run_dir) / "metrics.csv", tmp / "metrics.csv");
    fs::rename(tmp, dir);
  }
}

std::string member_dir(const std::string& run_dir, int m) {
  return (fs::path(run_dir) / "members" / std::to_string(m)).string();
}

std::string unfinished_tail_member(const std::string& run_dir, const TrainConfig& config) {
  for (int m = 1; m < config.loop.hl_tail_members; ++m) {
    const std::string member = member_dir(run_dir, m);
    const bool exists = fs::is_directory(member);
    const std::string latest = exists ? latest_checkpoint_name(member) : "";
    if (latest.empty())
      return member + (exists ? ": has no checkpoint yet" : ": missing") + ", so the run's policy (an ensemble of " +
             std::to_string(config.loop.hl_tail_members) +
             " tails, train.hl_tail_members) is incomplete; continue it with f16race train --resume " + run_dir;
    const fs::path dir = fs::path(member) / "checkpoint" / latest;
    std::int64_t steps = 0, budget = 0;
    try {
      const RunConfig mc = read_run_config(member);
      budget = static_cast<std::int64_t>(mc.config.loop.total_env_steps);
      steps = check_checkpoint_meta(dir.string(), mc.hash, CheckpointUse::policy);
    } catch (const std::exception& e) {
      throw io::InputError((dir / "meta.yaml").string() + ": cannot read tail member " + std::to_string(m) +
                           "'s checkpoint (" + checkpoint_error_reason(e) +
                           "); restore it, or move the run folder aside to retrain");
    }
    if (steps < budget)
      return member + ": tail member " + std::to_string(m) + " is at " + std::to_string(steps) + " of " +
             std::to_string(budget) + " env steps; finish it with f16race train --resume " + run_dir;
  }
  return "";
}

std::vector<TrainSummary> train_tail_members(const std::string& run_dir, const std::atomic<bool>* stop,
                                             const std::function<void(int, const MetricsRow&)>& on_row) {
  const RunConfig run = read_run_config(run_dir);
  std::vector<TrainSummary> out;
  for (int m = 1; m < run.config.loop.hl_tail_members; ++m) {
    const std::string dir = member_dir(run_dir, m);
    if (!fs::is_directory(dir))
      throw io::InputError(dir + ": missing, so tail member " + std::to_string(m) +
                           " was never forked: the run's HL-only tail (the last train.hl_tail_share of its env "
                           "steps) began and ended inside its last update, or the folder was removed; train the "
                           "run again, with a larger train.total_env_steps or train.hl_tail_share");
    auto member = Trainer::resume(dir);
    out.push_back(member->run(stop, -1, [&](const MetricsRow& r) {
      if (on_row) on_row(m, r);
    }));
    if (out.back().interrupted) break;
  }
  return out;
}

bool tail_members_due(const TrainConfig& config, const TrainSummary& run) {
  return config.loop.hl_tail_members > 1 && run.env_steps >= config.loop.total_env_steps;
}

TailEnsembleRun train_tail_ensemble(std::unique_ptr<Trainer> trainer, const std::string& run_dir,
                                    const TrainSummary& run, const std::atomic<bool>* stop,
                                    const std::function<void(int, const MetricsRow&)>& on_row) {
  TailEnsembleRun out;
  const bool due = tail_members_due(trainer->config(), run);
  trainer.reset();  // its lock stays until here; the members hold their own
  if (!due) return out;
  out.members = train_tail_members(run_dir, stop, on_row);
  out.interrupted = !out.members.empty() && out.members.back().interrupted;
  return out;
}

}  // namespace f16race::train
