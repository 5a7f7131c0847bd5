// `f16race train`: bilevel self-play training on a YAML config, resumable, with a progress line.
#include <omp.h>
#include <spdlog/spdlog.h>
#include <torch/torch.h>
#include <unistd.h>

#include <CLI/CLI.hpp>
#include <algorithm>
#include <atomic>
#include <cmath>
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
#include "train/trainer.hpp"

namespace f16race::app {
namespace {

std::atomic<bool> g_stop{false};
extern "C" void on_sigint(int) { g_stop.store(true); }

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

std::string fmt_time(double s) {
  if (!std::isfinite(s) || s < 0) return "--:--";
  char b[32];
  std::snprintf(b, sizeof b, "%d:%02d", static_cast<int>(s) / 60, static_cast<int>(s) % 60);
  return b;
}

// Change of a metric between the first and last tenth of the rows that have it (an update in
// which no race ended has no finish rate).
struct Trend {
  double first = NAN, last = NAN;
};
Trend trend(const std::vector<train::MetricsRow>& rows, double train::MetricsRow::*field) {
  std::vector<double> v;
  for (const auto& r : rows)
    if (std::isfinite(r.*field)) v.push_back(r.*field);
  Trend t;
  if (v.empty()) return t;
  const std::size_t n = v.size(), k = std::max<std::size_t>(1, n / 10);
  auto mean = [&](std::size_t a, std::size_t b) {
    double s = 0;
    for (std::size_t i = a; i < b; ++i) s += v[i];
    return s / static_cast<double>(b - a);
  };
  t.first = mean(0, k);
  t.last = mean(n - k, n);
  return t;
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
  std::unique_ptr<train::Trainer> trainer;
  std::string run_dir;  // the run folder trained (fresh or resumed)
  if (!o.resume.empty()) {
    if (!o.overrides.empty() || !o.agent.empty() || o.seed >= 0 || o.overwrite)
      throw io::InputError("--resume continues a run exactly as configured: drop --set/--agent/--seed/--overwrite");
    if (dc.world_size > 1) {
      std::ostringstream fp;
      fp << "binary " << std::hex << dist::executable_hash() << std::dec << "\ntrain --resume " << o.resume
         << "\n--max-updates " << o.max_updates;
      group = std::make_unique<dist::Group>(dc, fp.str());
    }
    trainer = train::Trainer::resume(o.resume, group.get());
    run_dir = o.resume;
    if (lead) spdlog::info("resuming {} at update {}", o.resume, trainer->updates());
  } else {
    YAML::Node root = io::load_yaml_with_overrides(o.config, o.overrides);
    if (!o.agent.empty()) io::apply_override(root, "hl.agent=" + o.agent);
    if (o.seed >= 0) io::apply_override(root, "seed=" + std::to_string(o.seed));
    const train::TrainConfig cfg = train::read_train_config(root, o.config);
    std::string run = o.run;
    if (run.empty()) {
      run = "runs/" + std::string(agents::es_variant_name(cfg.hl.variant)) + "_seed" + std::to_string(cfg.seed);
    }
    if (dc.world_size > 1) {
      // The resolved config, not the command line: a rank on another host reads its own copy of
      // the YAML file, and every rank must train the same configuration.
      std::ostringstream fp;
      fp << "binary " << std::hex << dist::executable_hash() << std::dec << "\ntrain --run " << run
         << "\n--max-updates " << o.max_updates << "\n--overwrite " << o.overwrite << "\n"
         << train::train_config_yaml(cfg);
      group = std::make_unique<dist::Group>(dc, fp.str());
    }
    if (lead && o.overwrite && !io::run_data_in(run).empty()) {
      std::string aside;
      {
        const io::RunFolderLock lock(run);  // not while another train writes it
        aside = io::move_run_aside(run);
      }
      spdlog::info("moved the run that was in {} aside to {}", run, aside);
    }
    trainer = std::make_unique<train::Trainer>(cfg, run, group.get());
    run_dir = run;
    if (lead)
      spdlog::info("run folder {}: {} envs x {} vs {}, agent {}, {} env steps, {} threads{}", run, cfg.race.n_env,
                   cfg.race.team_size, cfg.race.team_size, agents::es_variant_name(cfg.hl.variant),
                   cfg.loop.total_env_steps, threads,
                   dc.world_size > 1 ? fmt::format(" per rank, {} ranks of {} envs", dc.world_size,
                                                   cfg.race.n_env / dc.world_size)
                                     : std::string());
  }
  const train::TrainConfig cfg = trainer->config();  // a copy: the trainer goes before its tail members train
  const bool quiet = o.quiet || !lead;
  const bool tty = isatty(STDOUT_FILENO) != 0 && !quiet;
  std::string member_tag;  // "member m: " while train.hl_tail_members trains the run's other tails
  auto on_row = [&](const train::MetricsRow& r) {
    if (quiet) return;
    const double frac = static_cast<double>(r.env_steps) / static_cast<double>(cfg.loop.total_env_steps);
    const double eta = frac > 0 ? r.wall_s * (1.0 - frac) / frac : NAN;
    char line[400];
    std::snprintf(line, sizeof line,
                  "%s%5.1f%% %s ETA %s | upd %lld %s | %.0fk smp/s | goal %5.0f ft | %3.0f ft/s | win %.2f | "
                  "finish %.2f | LL ret %6.2f | HL ret %6.2f | HL Q spread %.3f, middle bin x/y/z %.2f/%.2f/%.2f",
                  member_tag.c_str(), 100.0 * frac, fmt_time(r.wall_s).c_str(), fmt_time(eta).c_str(), static_cast<long long>(r.update),
                  r.phase.c_str(), r.samples_per_s / 1000.0, r.goal_dist_ft, r.airspeed_ftps, r.winrate, r.finish_rate,
                  r.ll_return, r.hl_return, r.q_spread, r.middle_share[0], r.middle_share[1],
                  r.middle_share[2]);
    if (tty) {
      print_progress_bar(frac, 28, line);
    } else if (r.update % cfg.loop.log_every_updates == 0) {
      std::printf("%s\n", line);
      std::fflush(stdout);
    }
  };
  const train::TrainSummary sum = trainer->run(&g_stop, o.max_updates, on_row);
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
  // --max-updates may end the run before its budget: its tail members (forked at the tail's
  // start) train only after the run's own budget, when it is resumed to it.
  const bool budget_reached = sum.env_steps >= cfg.loop.total_env_steps;
  if (cfg.loop.hl_tail_members > 1 && budget_reached) {
    // The run's other tails, forked at its tail's first update: each as long as its own.
    trainer.reset();  // its lock stays until here; the members hold their own
    if (!quiet)
      std::printf("%sthe run's policy is an ensemble of %d high-level tails: training %s/members/1..%d\n",
                  tty ? "\n" : "", cfg.loop.hl_tail_members, run_dir.c_str(), cfg.loop.hl_tail_members - 1);
    const std::vector<train::TrainSummary> members =
        train::train_tail_members(run_dir, &g_stop, [&](int m, const train::MetricsRow& r) {
          member_tag = "member " + std::to_string(m) + ": ";
          on_row(r);
        });
    if (tty) std::printf("\n");
    if (!members.empty() && members.back().interrupted) {
      std::printf("interrupted: tail member %zu's checkpoint written; continue the run with --resume %s\n",
                  members.size(), run_dir.c_str());
      throw ExitStatus{130};
    }
  }
  // What improved, between the first and last tenth of this process's rows.
  const Trend goal = trend(sum.rows, &train::MetricsRow::goal_dist_ft);
  const Trend fin = trend(sum.rows, &train::MetricsRow::finish_rate);
  const Trend hl = trend(sum.rows, &train::MetricsRow::hl_return);
  const Trend ll = trend(sum.rows, &train::MetricsRow::ll_return);
  const Trend vt = trend(sum.rows, &train::MetricsRow::airspeed_ftps);
  std::printf("done: %lld updates, %lld env steps, %lld HL gradient steps\n", static_cast<long long>(sum.updates),
              static_cast<long long>(sum.env_steps), static_cast<long long>(sum.hl_grad_steps));
  if (!budget_reached)
    std::printf("stopped by --max-updates at %lld of %lld env steps (checkpoint written); continue with --resume %s\n",
                static_cast<long long>(sum.env_steps), static_cast<long long>(cfg.loop.total_env_steps),
                run_dir.c_str());
  else if (cfg.loop.hl_tail_members > 1)
    std::printf("high-level policy: greedy on the mean of %d tails' critics (the run's and %s/members/1..%d; "
                "train.hl_tail_members)\n",
                cfg.loop.hl_tail_members, run_dir.c_str(), cfg.loop.hl_tail_members - 1);
  if (dc.world_size > 1)
    std::printf("group of %d ranks: rank 0 spent %.0f%% of its time in collectives\n", dc.world_size,
                100.0 * sum.communication_s / std::max(sum.time.total, 1e-9));
  if (!sum.curves_problem.empty()) std::printf("no curves.png: %s\n", sum.curves_problem.c_str());
  if (sum.rows.empty()) return;  // a resumed run that had already reached its budget: no trend to show
  // Only what was measured: a run in which no race ended has no finish rate to compare.
  std::string line;
  auto add = [&](const char* name, const Trend& t, const char* format) {
    if (std::isnan(t.first)) return;
    char buf[96];
    std::snprintf(buf, sizeof buf, format, t.first, t.last);
    line += (line.empty() ? "" : ", ") + std::string(name) + " " + buf;
  };
  add("goal distance", goal, "%.0f -> %.0f ft");
  add("finish rate", fin, "%.2f -> %.2f");
  add("LL return", ll, "%.2f -> %.2f");
  add("HL return", hl, "%.2f -> %.2f");
  add("airspeed", vt, "%.0f -> %.0f ft/s");
  if (line.empty()) std::printf("no race ended in this run yet: nothing to compare between its first and last tenth\n");
  else std::printf("first -> last tenth: %s\n", line.c_str());
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
