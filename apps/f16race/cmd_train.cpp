// `f16race train`: bilevel self-play training on a YAML config, resumable, with a progress line.
#include <omp.h>
#include <spdlog/spdlog.h>
#include <torch/torch.h>
#include <unistd.h>

#include <CLI/CLI.hpp>
#include <atomic>
#include <csignal>
#include <cstdio>
#include <memory>
#include <sstream>
#include <string>
#include <vector>

#include "commands.hpp"
#include "dist/process_group.hpp"
#include "dist_options.hpp"
#include "progress_bar.hpp"
#include "io/run_folder.hpp"
#include "io/yaml_config.hpp"
#include "train/tail_ensemble.hpp"
#include "train/train_report.hpp"
#include "train/trainer.hpp"

namespace f16race::app {
namespace {

std::atomic<bool> g_train_stop{false};
extern "C" void on_sigint(int) { g_train_stop.store(true); }

struct TrainOptions {
  std::string config = "configs/default.yaml";
  std::vector<std::string> overrides;
  std::string run;
  std::string resume;
  std::string agent;
  long long seed = -1;
  long long max_updates = -1;
  bool quiet = false;
  bool overwrite = false;
  std::string log_level = "info";
};

// The run --resume names; with a group (WORLD_SIZE > 1), this process's rank of it in `group`.
std::unique_ptr<train::Trainer> resume_trainer(const TrainOptions& o, const dist::DistConfig& dc,
                                               std::unique_ptr<dist::Group>* group) {
  if (!o.overrides.empty() || !o.agent.empty() || o.seed >= 0 || o.overwrite)
    throw io::InputError("--resume continues a run exactly as configured: drop --set/--agent/--seed/--overwrite");
  if (dc.world_size > 1) {
    std::ostringstream fp;
    fp << "binary " << std::hex << dist::executable_hash() << std::dec << "\ntrain --resume " << o.resume
       << "\n--max-updates " << o.max_updates;
    *group = std::make_unique<dist::Group>(dc, fp.str());
  }
  auto trainer = train::Trainer::resume(o.resume, group->get());
  if (dc.rank == 0) spdlog::info("resuming {} at update {}", o.resume, trainer->updates());
  return trainer;
}

// A new run of --config (with --set, --agent, --seed) in `*run_dir` (--run, or runs/AGENT_seedN).
std::unique_ptr<train::Trainer> start_trainer(const TrainOptions& o, const dist::DistConfig& dc, int threads,
                                              std::unique_ptr<dist::Group>* group, std::string* run_dir) {
  YAML::Node root = io::load_yaml_with_overrides(o.config, o.overrides);
  if (!o.agent.empty()) io::apply_override(root, "hl.agent=" + o.agent);
  if (o.seed >= 0) io::apply_override(root, "seed=" + std::to_string(o.seed));
  const train::TrainConfig cfg = train::read_train_config(root, o.config);
  const std::string run = !o.run.empty() ? o.run
                                         : "runs/" + std::string(agents::es_variant_name(cfg.hl.variant)) + "_seed" +
                                               std::to_string(cfg.seed);
  if (dc.world_size > 1) {
    // The resolved config, not the command line: a rank on another host reads its own copy of
    // the YAML file, and every rank must train the same configuration.
    std::ostringstream fp;
    fp << "binary " << std::hex << dist::executable_hash() << std::dec << "\ntrain --run " << run
       << "\n--max-updates " << o.max_updates << "\n--overwrite " << o.overwrite << "\n"
       << train::train_config_yaml(cfg);
    *group = std::make_unique<dist::Group>(dc, fp.str());
  }
  if (dc.rank == 0 && o.overwrite && !io::run_data_in(run).empty()) {
    std::string aside;
    {
      const io::RunFolderLock lock(run);  // not while another train writes it
      aside = io::move_run_aside(run);
    }
    spdlog::info("moved the run that was in {} aside to {}", run, aside);
  }
  auto trainer = std::make_unique<train::Trainer>(cfg, run, group->get());
  *run_dir = run;
  if (dc.rank == 0)
    spdlog::info("run folder {}: {} envs x {} vs {}, agent {}, {} env steps, {} threads{}", run, cfg.race.n_env,
                 cfg.race.team_size, cfg.race.team_size, agents::es_variant_name(cfg.hl.variant),
                 cfg.loop.total_env_steps, threads,
                 dc.world_size > 1 ? fmt::format(" per rank, {} ranks of {} envs", dc.world_size,
                                                 cfg.race.n_env / dc.world_size)
                                   : std::string());
  return trainer;
}

void run_train(const TrainOptions& o, const dist::DistConfig& dc) {
  spdlog::set_level(spdlog::level::from_str(o.log_level));
  // From the start: a stop while the run is being set up ends it after its first update, with a
  // checkpoint, instead of killing it mid-setup.
  std::signal(SIGINT, on_sigint);
  std::signal(SIGTERM, on_sigint);
  // Torch's intra-op pool and the simulator's OpenMP never run at the same time; one count.
  const int threads = omp_get_max_threads();
  torch::set_num_threads(threads);
  // One rank of a data-parallel group (issue 18) when WORLD_SIZE > 1; rank 0 alone prints and
  // writes the run folder.
  const bool lead = dc.rank == 0;
  std::unique_ptr<dist::Group> group;
  std::string run_dir = o.resume;  // the run folder trained (fresh or resumed)
  std::unique_ptr<train::Trainer> trainer =
      o.resume.empty() ? start_trainer(o, dc, threads, &group, &run_dir) : resume_trainer(o, dc, &group);
  const train::TrainConfig cfg = trainer->config();  // a copy: the trainer goes before its tail members train
  const bool quiet = o.quiet || !lead;
  const bool tty = isatty(STDOUT_FILENO) != 0 && !quiet;
  std::string member_tag;  // "member m: " while train.hl_tail_members trains the run's other tails
  auto on_row = [&](const train::MetricsRow& r) {
    if (quiet) return;
    const std::string line = train::progress_line(r, cfg.loop.total_env_steps, member_tag);
    if (tty) {
      print_progress_bar(static_cast<double>(r.env_steps) / static_cast<double>(cfg.loop.total_env_steps), 28, line);
    } else if (r.update % cfg.loop.log_every_updates == 0) {
      std::printf("%s\n", line.c_str());
      std::fflush(stdout);
    }
  };
  const train::TrainSummary sum = trainer->run(&g_train_stop, o.max_updates, on_row);
  if (tty) std::printf("\n");
  if (!lead) {
    if (sum.interrupted) throw ExitStatus{130};
    return;
  }
  if (sum.interrupted) {
    std::printf("interrupted: checkpoint written at update %lld; continue with --resume\n",
                static_cast<long long>(sum.updates));
    throw ExitStatus{130};  // as a shell reports a command ended by SIGINT, after the checkpoint
  }
  if (train::tail_members_due(cfg, sum)) {  // the run's other tails, forked at its tail's first update
    if (!quiet)
      std::printf("%sthe run's policy is an ensemble of %d high-level tails: training %s/members/1..%d\n",
                  tty ? "\n" : "", cfg.loop.hl_tail_members, run_dir.c_str(), cfg.loop.hl_tail_members - 1);
    const train::TailEnsembleRun tails =
        train::train_tail_ensemble(std::move(trainer), run_dir, sum, &g_train_stop, [&](int m, const train::MetricsRow& r) {
          member_tag = "member " + std::to_string(m) + ": ";
          on_row(r);
        });
    if (tty) std::printf("\n");
    if (tails.interrupted) {
      std::printf("interrupted: tail member %zu's checkpoint written; continue the run with --resume %s\n",
                  tails.members.size(), run_dir.c_str());
      throw ExitStatus{130};
    }
  }
  std::printf("%s", train::summary_text(sum, cfg, run_dir, dc.world_size).c_str());
}

}  // namespace

void add_train_command(CLI::App& app) {
  auto o = std::make_shared<TrainOptions>();
  CLI::App* cmd = app.add_subcommand("train", "Bilevel self-play training (PPO low level, Expected SARSA high level)");
  cmd->add_option("--config", o->config, "YAML config");
  cmd->add_option("--set", o->overrides, "Override a key, e.g. --set race.n_env=128 (repeatable)");
  cmd->add_option("--run", o->run, "Run folder (default runs/AGENT_seedN)");
  cmd->add_option("--resume", o->resume, "Continue the run in this folder from its latest checkpoint");
  cmd->add_option("--agent", o->agent, "High-level agent: es, es_d1, es_d2, es_d3")
      ->check(CLI::IsMember({"es", "es_d1", "es_d2", "es_d3"}));
  cmd->add_option("--seed", o->seed, "Seed (overrides the config's)")->check(kNonNegativeSeed);
  CLI::Option* max_updates = cmd->add_option("--max-updates", o->max_updates, "Stop (with a checkpoint) after this many updates");
  cmd->add_flag("--quiet", o->quiet, "No progress output");
  cmd->add_flag("--overwrite", o->overwrite,
                "Start afresh in a --run folder that holds a run, moving the old one aside to RUN.old-N");
  cmd->add_option("--log-level", o->log_level, "trace, debug, info, warn, error")
      ->check(CLI::IsMember({"trace", "debug", "info", "warn", "error", "critical", "off"}));
  auto dist_flags = std::make_shared<DistFlags>();
  dist_flags->add_to(cmd);
  cmd->callback([o, dist_flags, max_updates]() {
    if (max_updates->count() > 0 && o->max_updates < 1)
      throw io::InputError("--max-updates " + std::to_string(o->max_updates) + ": must be at least 1 (leave it out to "
                           "train to the run's budget)");
    run_train(*o, dist_flags->resolve());
  });
}

}  // namespace f16race::app
