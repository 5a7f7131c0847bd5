// `f16race bench train`: end-to-end training throughput (aircraft LL steps per second including
// inference and both learners' updates) with a breakdown of where the time goes and the network
// floor (what the networks alone allow), for the default and the paper configuration shapes.
// The measurements and their report are lib/bench's (train_bench, train_bench_report); this file
// parses the options and prints.
#include <omp.h>
#include <torch/torch.h>

#include <CLI/CLI.hpp>
#include <cstdio>
#include <memory>
#include <string>
#include <vector>

#include "bench/train_bench.hpp"
#include "bench/train_bench_report.hpp"
#include "commands.hpp"
#include "dist/process_group.hpp"
#include "dist_options.hpp"
#include "io/json_text.hpp"
#include "io/numeric_mode.hpp"
#include "io/provenance.hpp"
#include "io/yaml_config.hpp"

namespace f16race::app {
namespace {

struct TrainBenchOptions {
  // paper.yaml (1024 envs) is not a default: one of its ES updates alone collects 8 M aircraft
  // steps, tens of minutes on a 2-core machine.
  std::vector<std::string> configs{"configs/default.yaml"};
  std::vector<std::string> overrides;
  long long updates = 20;
  int repeat = 4;  // runs, alternating with the floor's timings; the first is dropped when > 1
  bool json = false;
  int nproc = 1;  // >1: as a group of ranks on this host (issue 18)
};

// `bench train` as one rank of a group (started by --nproc through launch): the group trains one
// run; each rank reports its own throughput and its time inside collectives, rank 0 prints them.
// On one host the ranks share its cores, so this measures the cost of the group, not a speed-up.
void run_bench_train_rank(const TrainBenchOptions& o, const std::vector<train::TrainConfig>& configs,
                          const dist::DistConfig& dc) {
  torch::set_num_threads(omp_get_max_threads());
  dist::Group group(dc, bench::train_bench_fingerprint(o.updates, o.configs, o.overrides));
  const bool lead = group.rank() == 0;
  if (lead && !o.json)
    std::printf("f16race bench train: %lld updates per config, a group of %d ranks x %d threads on this host\n",
                o.updates, group.size(), omp_get_max_threads());
  for (std::size_t c = 0; c < o.configs.size(); ++c) {
    const std::string& path = o.configs[c];
    const train::TrainConfig& cfg = configs[c];
    const bench::GroupTrainBench g = bench::bench_training_in_group(cfg, o.updates, group);
    if (!lead) continue;
    const int n_agent = 2 * cfg.race.team_size;
    if (o.json) {
      std::string per_rank, comm;
      for (int r = 0; r < group.size(); ++r) {
        per_rank += (r ? ", " : "") + std::to_string(g.rank_rate[r]);
        comm += (r ? ", " : "") + std::to_string(g.rank_communication_share[r]);
      }
      std::printf("{\"bench\": \"train\", \"config\": %s, \"envs\": %d, \"ranks\": %d, \"threads_per_rank\": %d, "
                  "\"aircraft_steps_per_s\": %.6g, \"per_rank_aircraft_steps_per_s\": [%s], "
                  "\"communication_share\": [%s]}\n",
                  io::json_string(path).c_str(), cfg.race.n_env, group.size(), omp_get_max_threads(), g.rate,
                  per_rank.c_str(), comm.c_str());
    } else {
      std::printf("%s: %d envs x %d aircraft over %d ranks, %lld env steps in %.1f s -> %.0f aircraft-steps/s for the "
                  "group\n",
                  path.c_str(), cfg.race.n_env, n_agent, group.size(), static_cast<long long>(g.env_steps), g.slowest_s,
                  g.rate);
      for (int r = 0; r < group.size(); ++r)
        std::printf("  rank %d: %d envs, %.0f aircraft-steps/s, %.0f%% of its time in collectives\n", r,
                    cfg.race.n_env / group.size(), g.rank_rate[r], 100.0 * g.rank_communication_share[r]);
    }
    std::fflush(stdout);
  }
}

void run_bench_train(const TrainBenchOptions& o, const dist::DistConfig& dc, int threads_option) {
  // Every config read and checked before anything is launched or timed: a bad key in the last
  // one fails at once, not after minutes of benchmarks of the others.
  std::vector<train::TrainConfig> configs;
  for (const std::string& path : o.configs)
    configs.push_back(train::read_train_config(io::load_yaml_with_overrides(path, o.overrides), path));
  if (dc.world_size > 1) return run_bench_train_rank(o, configs, dc);
  if (o.nproc > 1) {
    // The same bench as ranks of a group, started by launch on loopback.
    std::vector<std::string> command{"bench", "train", "--updates", std::to_string(o.updates)};
    for (const std::string& c : o.configs) command.insert(command.end(), {"--config", c});
    for (const std::string& v : o.overrides) command.insert(command.end(), {"--set", v});
    if (o.json) command.push_back("--json");
    launch_ranks(o.nproc, command, threads_option, 60.0);
    return;
  }
  torch::set_num_threads(omp_get_max_threads());
  if (!o.json) {
    const std::string blas = io::blas_core();
    std::printf("f16race bench train: %d runs of %lld updates per config (LL and HL phases as configured), %d "
                "threads; %s, %s build, OpenBLAS kernels %s\n",
                o.repeat, o.updates, omp_get_max_threads(), io::cpu_model().c_str(), io::numeric_mode_name(),
                blas.empty() ? "- (not OpenBLAS)" : blas.c_str());
  }
  for (std::size_t c = 0; c < o.configs.size(); ++c) {
    const bench::TrainBenchResult res = bench::bench_training(configs[c], o.updates, o.repeat);
    const std::string report = o.json ? bench::train_bench_json(o.configs[c], configs[c], res)
                                      : bench::train_bench_text(o.configs[c], configs[c], res);
    std::fputs(report.c_str(), stdout);
    std::fflush(stdout);
  }
}

}  // namespace

void add_bench_train_command(CLI::App& bench, const int& threads_option) {
  auto o = std::make_shared<TrainBenchOptions>();
  CLI::App* cmd = bench.add_subcommand("train", "End-to-end training throughput with a time breakdown");
  cmd->add_option("--config", o->configs, "Configs to measure (default: configs/default.yaml; paper.yaml takes tens of minutes on 2 cores)");
  cmd->add_option("--updates", o->updates, "Updates per config")->check(CLI::Range(1, 100000));
  cmd->add_option("--set", o->overrides, "Override a key of every config, e.g. --set race.n_env=256 (repeatable)");
  cmd->add_option("--repeat", o->repeat,
                  "Runs per config, alternating with the floor's timings; the first (cold) is dropped when > 1 and "
                  "medians are reported")
      ->check(CLI::Range(1, 100));
  cmd->add_flag("--json", o->json, "One JSON object per config, one per line");
  cmd->add_option("--nproc", o->nproc,
                  "Train as a group of this many ranks on this host (each --threads, default the cores' share): "
                  "per-rank throughput and time in collectives")
      ->check(CLI::Range(1, 256));
  auto dist_flags = std::make_shared<DistFlags>();
  dist_flags->add_to(cmd);
  const int* threads = &threads_option;
  cmd->callback([o, dist_flags, threads]() { run_bench_train(*o, dist_flags->resolve(), *threads); });
}

}  // namespace f16race::app
