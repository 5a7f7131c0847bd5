// Checkpoint folders RUN/checkpoint/step_N_uK/ (ll.pt, hl.pt, trainer.pt per rank, meta.yaml) and
// the LATEST pointer that commits them: written at the update loop's checkpoints, read at a resume.
#include <torch/torch.h>
#include <yaml-cpp/yaml.h>

#include <chrono>
#include <cstdio>
#include <filesystem>
#include <fstream>
#include <sstream>
#include <stdexcept>
#include <string>
#include <vector>

#include "dist/process_group.hpp"
#include "io/atomic_file.hpp"
#include "io/byte_hash.hpp"
#include "train/checkpoint_archive.hpp"
#include "train/run_numerics.hpp"
#include "train/trainer_state.hpp"

namespace f16race::train {

namespace fs = std::filesystem;

template <class V>
void Trainer::State::visit_checkpoint(V& v, std::uint64_t& stream_state) {
  v.bytes("env", [&](std::ostream& out) { env->save_state(out); }, [&](std::istream& in) { env->load_state(in); });
  v.integers("counters", env_steps, ppo_updates, es_updates, phase, phase_updates, opponent, hl_grad_steps);
  v.integer_list("pool", pool.steps(), false);
  v.integer_list("side", side, true);
  v.integer_list("vs_pool", vs_pool, true);
  v.integers("stream", stream_state);
  v.tensor("open_ego", open.obs.ego);
  v.tensor("open_prev_action", open.obs.prev_action);
  v.tensor("open_ado", open.obs.ado);
  v.tensor("open_alive", open.obs.ado_alive);
  v.tensor("open_task", open.obs.task);
  v.tensor("open_actions", open.actions);
  v.tensor("open_reward", open.reward);
  v.tensor("open_active", open.active);
  v.integer_list("open_flag", open.open, true);
  v.real_list("returns", ll_ret);
  v.real_list("hl_returns", hl_ret);
  // The last updates' statistics, so metrics rows after a resume match an unbroken run.
  v.reals("last_stats", last_ppo.policy_loss, last_ppo.value_loss, last_ppo.entropy, last_ppo.approx_kl,
          last_ppo.learning_rate, last_es.loss, last_es.q_mean, last_es.end_atom_share, last_es.huber_share,
          last_es.q_spread, last_es.greedy_entropy, last_es.off_center_share, last_es.loss_before);
  // Added after the key above was fixed: checkpoints written before it resume with nan here.
  v.optional_reals("last_middle_share", last_es.middle_share[0], last_es.middle_share[1], last_es.middle_share[2]);
  // Only with tail members, so the checkpoints of every other run keep their bytes.
  if (has_tail_members()) {
    double started = tail_started ? 1.0 : 0.0;
    v.optional_reals("tail_started", started);
    tail_started = started != 0.0;
  }
}

namespace {
// The run's wall time at the checkpoint (seconds, text): metrics' wall_s continues from it.
constexpr const char* kWallFile = "wall_s.txt";
// A rank's trainer state in a checkpoint folder: rank 0's is a single process's file.
std::string trainer_file(int rank) { return rank == 0 ? "trainer.pt" : "trainer_rank" + std::to_string(rank) + ".pt"; }

std::uint64_t module_hash(const torch::nn::Module& m, std::uint64_t h) {
  for (const auto& list : {m.parameters(), m.buffers()})
    for (const auto& t : list) {
      const auto c = t.detach().contiguous();
      h = io::fnv1a(c.data_ptr(), static_cast<std::size_t>(c.nbytes()), h);
    }
  return h;
}
}  // namespace

void Trainer::State::check_replicas_agree() {
  std::uint64_t h = module_hash(*ppo->net(), io::kFnv1aOffset);
  h = module_hash(*ppo->normalizer(), h);
  h = module_hash(*es->critic(), h);
  h = module_hash(*es->normalizer(), h);
  // Two exact halves in doubles.
  const std::vector<double> all = group->allgather({static_cast<double>(h >> 32), static_cast<double>(h & 0xFFFFFFFFULL)});
  for (int r = 1; r < world; ++r)
    if (all[2 * r] != all[0] || all[2 * r + 1] != all[1])
      throw std::runtime_error("rank " + std::to_string(r) + "'s networks differ from rank 0's at update " +
                               std::to_string(ppo_updates + es_updates) +
                               ": the replicas diverged (a bug: please report it); the last checkpoint is intact");
}

std::string Trainer::State::trainer_state_bytes() {
  CheckpointWriter w;
  std::uint64_t stream_state = stream.state();
  visit_checkpoint(w, stream_state);
  w.a.write("generator", gen.get_state());
  if (world > 1) {  // ll.pt and hl.pt hold rank 0's minibatch order
    w.a.write("ppo_minibatch_generator", ppo->minibatch_generator().get_state());
    w.a.write("es_minibatch_generator", es->minibatch_generator().get_state());
  }
  std::ostringstream bytes;
  w.a.save_to(bytes);
  return bytes.str();
}

void Trainer::State::save_checkpoint(bool last) {
  const std::string name = step_name(env_steps) + "_u" + std::to_string(ppo_updates + es_updates);
  const fs::path dir = fs::path(run_dir) / "checkpoint" / name;
  // Every rank's trainer state as bytes; in a group they go to rank 0, which writes the folder.
  std::vector<std::string> states{trainer_state_bytes()};
  if (group != nullptr) {
    check_replicas_agree();
    states = group->allgather_bytes(states[0]);
    if (!writes()) {
      pool.release_retired(opponent);
      return;
    }
  }
  // The run's last figure is drawn on the curves thread beside the last checkpoint's writes; run()
  // waits for it after this returns, timed apart as TimeBreakdown::run_end (one draw path; the
  // overlap saves little: 32-env bench train on the Intel VM, gnuplot 0.09-0.15 s, the files 6-7
  // ms). metrics.csv holds the last row.
  const auto now = std::chrono::steady_clock::now();
  if (last) redraw_curves(now);
  const std::string previous = latest_checkpoint_name(run_dir);
  // A checkpoint that cannot be completed (full disk) is removed whole; LATEST still names the
  // previous one, which stays intact.
  try {
    fs::create_directories(dir);
    ppo->save((dir / "ll.pt").string());
    es->save((dir / "hl.pt").string());
    for (int r = 0; r < world; ++r) io::write_file_atomic((dir / trainer_file(r)).string(), states[static_cast<std::size_t>(r)]);
    char wall_s[32];
    std::snprintf(wall_s, sizeof wall_s, "%.17g\n", wall());
    io::write_file_atomic((dir / kWallFile).string(), wall_s);
    std::ostringstream meta;
    meta << "format: " << kCheckpointFormat << "\nconfig_hash: " << hash << "\nenv_steps: " << env_steps
         << "\nupdates: " << ppo_updates + es_updates << "\n";
    if (world > 1) meta << "world_size: " << world << "\n";
    meta << numerics_meta_lines();  // the mode these weights were computed in
    io::write_file_atomic((dir / "meta.yaml").string(), meta.str());
    // The pointer flips only once the folder is complete; then older checkpoints go.
    io::write_file_atomic(run_dir + "/checkpoint/LATEST", name);
  } catch (...) {
    std::error_code ec;
    fs::remove_all(dir, ec);
    throw;
  }
  if (!previous.empty() && previous != name) fs::remove_all(fs::path(run_dir) / "checkpoint" / previous);
  // Only now may the pool's retired snapshots go: the checkpoint that named them is replaced.
  pool.release_retired(opponent);
  // The learning-curve figure follows the checkpoints, at most every kCurvesEvery (and at the
  // last): a gnuplot draw takes ~0.07 s, and with a checkpoint every ~2.5 s (default config, 2
  // threads) the draws were ~3 % of the run (bench train, 150 updates: I/O 0.79-0.86 s -> 0.26-0.28
  // s of ~20 s). Without gnuplot only its data and script. A figure that cannot be drawn never
  // stops training: the reason goes to the final summary. Draws before the last run beside
  // training (io::BackgroundCurves; bench train, 32 envs: I/O 0.23-0.25 s of ~6 s with gnuplot,
  // 0.03 s without); one still under way skips a draw; run() waits for the last (started above).
  constexpr auto kCurvesEvery = std::chrono::seconds(30);
  if (last) return;
  if (curves_drawn_at && now - *curves_drawn_at < kCurvesEvery) return;
  if (curves.busy()) return;
  redraw_curves(now);
}

std::string latest_checkpoint_name(const std::string& run_dir) {
  std::ifstream f(run_dir + "/checkpoint/LATEST");
  std::string name;
  f >> name;
  return name;
}

std::string checkpoint_error_reason(const std::exception& e) {
  std::string what = e.what();
  if (const auto nl = what.find('\n'); nl != std::string::npos) what.resize(nl);
  if (what.size() > 160) what.resize(160);
  return what;
}

std::int64_t check_checkpoint_meta(const std::string& checkpoint_dir, std::uint64_t expected_config_hash,
                                   CheckpointUse use) {
  const YAML::Node meta = YAML::LoadFile(checkpoint_dir + "/meta.yaml");
  const int format = meta["format"].as<int>();
  const int oldest = use == CheckpointUse::policy ? kOldestPolicyFormat : kCheckpointFormat;
  if (format < oldest || format > kCheckpointFormat)
    throw std::runtime_error("checkpoint format " + meta["format"].as<std::string>() + ", this build reads " +
                             (oldest == kCheckpointFormat ? "" : std::to_string(oldest) + " to ") +
                             std::to_string(kCheckpointFormat) +
                             (use == CheckpointUse::resume && format < oldest && format >= kOldestPolicyFormat
                                  ? " to resume (its policy can still be raced, replayed and exported)"
                                  : ""));
  if (meta["config_hash"].as<std::uint64_t>() != expected_config_hash)
    throw std::runtime_error("it was written with a different config.yaml (hash mismatch); restore that file");
  return meta["env_steps"].as<std::int64_t>();
}

// Rank 0's reading of the LATEST checkpoint, for every rank.
struct CheckpointFiles {
  fs::path dir, file;  // the folder, and the file being read (for the error message)
  std::string ll, hl;
  std::string wall_s;  // kWallFile's text; empty for a checkpoint written before it (trainer.pt held it)
  std::vector<std::string> states;  // trainer.pt of each rank
};

void Trainer::State::read_checkpoint_files(CheckpointFiles* f) const {
  const std::string name = latest_checkpoint_name(run_dir);
  if (name.empty()) throw io::InputError(run_dir + ": no checkpoint to resume from (checkpoint/LATEST missing or empty)");
  f->dir = fs::path(run_dir) / "checkpoint" / name;
  f->file = f->dir / "meta.yaml";
  int written_by = 1;
  bool policy_only = false;
  try {
    check_checkpoint_meta(f->dir.string(), hash);
    const YAML::Node meta = YAML::LoadFile(f->file.string());
    written_by = meta["world_size"] ? meta["world_size"].as<int>() : 1;
    policy_only = meta["policy_only"] && meta["policy_only"].as<bool>();
    if (policy_only) written_by = world;  // refused below, with its own reason
    if (written_by == world && !policy_only) {
      f->file = f->dir / "ll.pt";
      f->ll = io::read_file(f->file.string());
      f->file = f->dir / "hl.pt";
      f->hl = io::read_file(f->file.string());
      for (int r = 0; r < world; ++r) {
        f->file = f->dir / trainer_file(r);
        f->states[static_cast<std::size_t>(r)] = io::read_file(f->file.string());
      }
      f->file = f->dir / kWallFile;
      if (fs::exists(f->file)) f->wall_s = io::read_file(f->file.string());
    }
  } catch (const std::exception& e) {
    throw io::InputError(f->file.string() + ": cannot resume from this checkpoint (" + checkpoint_error_reason(e) +
                         "); the file is corrupt, truncated or from another build: restore it or train again");
  }
  if (policy_only)
    throw io::InputError(f->dir.string() + ": a policy-only copy (f16race export --policy-run), without the optimiser "
                         "and trainer state a resume needs; resume the run it was copied from, or train a new run");
  if (written_by != world)
    throw io::InputError(
        f->file.string() + ": this checkpoint was written by " +
        (written_by == 1 ? std::string("one process; resume it with one process (no WORLD_SIZE, no launch)")
                         : "a group of " + std::to_string(written_by) +
                               " ranks, each holding its envs' states; resume it with f16race launch --nproc " +
                               std::to_string(written_by) + " -- train --resume " + run_dir));
}

std::string Trainer::State::restore_checkpoint(const CheckpointFiles& files, const std::string& trainer_bytes) {
  const std::string where = files.dir.empty() ? run_dir + "/checkpoint (rank 0's)" : files.dir.string();
  std::string part = "ll.pt";
  try {
    ppo->load_bytes(files.ll);
    part = "hl.pt";
    es->load_bytes(files.hl);
    part = trainer_file(rank);
    CheckpointReader r;
    r.a.load_from(trainer_bytes.data(), trainer_bytes.size());
    std::uint64_t stream_state = 0;
    visit_checkpoint(r, stream_state);
    // The run's wall time so far continues its metrics' wall_s; older trainer.pt files held it.
    torch::Tensor old_wall;
    if (r.a.try_read("wall", old_wall))
      wall_offset = old_wall.item<double>();
    else
      wall_offset = files.wall_s.empty() ? 0.0 : std::stod(files.wall_s);
    stream.set_state(stream_state);
    gen.set_state(r.get("generator"));
    if (world > 1) {
      ppo->minibatch_generator().set_state(r.get("ppo_minibatch_generator"));
      es->minibatch_generator().set_state(r.get("es_minibatch_generator"));
    }
  } catch (const std::exception& e) {
    return where + "/" + part + ": cannot resume from this checkpoint (" + checkpoint_error_reason(e) +
           "); the file is corrupt, truncated or from another build: restore it or train again";
  }
  return "";
}

void Trainer::State::reload_opponent() {
  if (opponent < 0) return;
  try {
    load_pool_snapshot();
  } catch (const io::InputError&) {
    throw;
  } catch (const dist::PeerLost&) {
    throw;
  } catch (const std::exception& e) {
    throw io::InputError(run_dir + "/pool/" + step_name(opponent) + ": cannot load the pool snapshot this checkpoint plays (" +
                         checkpoint_error_reason(e) + "); restore it or train again");
  }
}

void Trainer::State::load_checkpoint() {
  // Rank 0 (or the single process) reads the files; in a group it sends every rank its part and
  // a problem found on any rank is every rank's one line.
  std::string problem;
  CheckpointFiles files;
  files.states.resize(static_cast<std::size_t>(world));
  if (writes()) {
    try {
      read_checkpoint_files(&files);
    } catch (const std::exception& e) {
      problem = e.what();
    }
  }
  std::string mine = files.states[0];
  if (group != nullptr) {
    group->broadcast_bytes(problem);
    if (problem.empty()) {
      group->broadcast_bytes(files.ll);
      group->broadcast_bytes(files.hl);
      group->broadcast_bytes(files.wall_s);
      for (int r = 0; r < world; ++r) {
        std::string bytes = files.states[static_cast<std::size_t>(r)];
        group->broadcast_bytes(bytes);
        if (r == rank) mine = std::move(bytes);
      }
    }
  }
  if (!problem.empty()) throw io::InputError(problem);
  // Parse on every rank; any rank's failure stops them all with its line.
  const std::string what_failed = restore_checkpoint(files, mine);
  if (group != nullptr)
    for (const std::string& p : group->allgather_bytes(what_failed))
      if (!p.empty()) throw io::InputError(p);
  if (!what_failed.empty()) throw io::InputError(what_failed);
  t0 = std::chrono::steady_clock::now();
  wall_at_row = wall_offset;
  steps_at_row = env_steps;
  // Snapshots taken after this checkpoint (or retired by it) are taken again or dropped again, and
  // a checkpoint folder whose LATEST was never written is written again.
  pool.remove_unnamed(opponent);
  if (writes()) remove_uncommitted_checkpoints();
  reload_opponent();
  if (writes()) truncate_metrics();
}

void Trainer::State::remove_uncommitted_checkpoints() const {
  const std::string latest = latest_checkpoint_name(run_dir);
  std::error_code ec;
  std::vector<fs::path> doomed;
  for (const auto& entry : fs::directory_iterator(fs::path(run_dir) / "checkpoint", ec))
    if (entry.is_directory(ec) && entry.path().filename() != latest) doomed.push_back(entry.path());
  for (const fs::path& p : doomed) fs::remove_all(p, ec);
}

}  // namespace f16race::train
