// `f16race bench train`: end-to-end training throughput (aircraft LL steps per second including
// inference and both learners' updates) with a breakdown of where the time goes and the network
// floor (what the networks alone allow), for the default and the paper configuration shapes.
// The measurements are lib/bench's (train_bench); this file parses and prints.
#include <omp.h>
#include <torch/torch.h>

#include <CLI/CLI.hpp>
#include <cstdio>
#include <memory>
#include <string>
#include <vector>

#include "bench/train_bench.hpp"
#include "commands.hpp"
#include "dist/process_group.hpp"
#include "dist_options.hpp"
#include "io/json_text.hpp"
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

// "a, b, c": each value in `fmt`.
std::string joined(const std::vector<double>& v, const char* fmt) {
  std::string out;
  char buf[64];
  for (std::size_t k = 0; k < v.size(); ++k) {
    std::snprintf(buf, sizeof buf, fmt, v[k]);
    out += (k ? ", " : "") + std::string(buf);
  }
  return out;
}

// One JSON object for one config: the medians, the median run's breakdown and floor, every run's figures.
void print_train_json(const std::string& path, const train::TrainConfig& cfg, const bench::TrainBenchResult& res) {
  const int n_agent = 2 * cfg.race.team_size;
  const bench::TrainBenchRun& mid = res.runs[res.median_run];
  const train::TrainSummary& s = mid.summary;
  const bench::NetworkFloor& floor = mid.floor;
  const auto& t = s.time;
  std::printf("{\"bench\": \"train\", \"config\": %s, \"envs\": %d, \"aircraft\": %d, \"threads\": %d, "
              "\"env_steps\": %lld, \"aircraft_steps_per_s\": %.6g, \"env_s\": %.4g, \"inference_s\": %.4g, \"ppo_s\": %.4g, "
              "\"es_s\": %.4g, \"io_s\": %.4g, \"other_s\": %.4g, \"run_end_s\": %.6g, \"total_s\": %.6g, "
              "\"ppo_chunk_wait_s\": %.4g, \"es_chunk_wait_s\": %.4g, "
              "\"floor_aircraft_steps_per_s\": %.6g, \"floor_ll_forward_s\": %.4g, \"floor_ll_train_s\": %.4g, "
              "\"floor_hl_forward_s\": %.4g, \"floor_hl_train_s\": %.4g, \"ll_forward_batch\": %lld, "
              "\"ll_train_batch\": %lld, \"hl_forward_batch\": %lld, \"hl_train_batch\": %lld, "
              "\"ll_forward_alive_share\": %.4g, \"ll_train_alive_share\": %.4g, \"hl_forward_alive_share\": %.4g, "
              "\"hl_train_alive_share\": %.4g, "
              "\"floor_ratio\": %.4g, \"runs\": %zu, \"runs_aircraft_steps_per_s\": [%s], "
              "\"runs_floor_aircraft_steps_per_s\": [%s], \"runs_floor_ratio\": [%s], \"runs_env_s\": [%s], "
              "\"runs_inference_s\": [%s], \"runs_ppo_s\": [%s], \"runs_es_s\": [%s], \"runs_io_s\": [%s], "
              "\"runs_ppo_chunk_wait_s\": [%s], \"runs_run_end_s\": [%s], "
              "\"cpu\": %s, \"blas_core\": %s}\n",
              io::json_string(path).c_str(), cfg.race.n_env, cfg.race.n_env * n_agent, omp_get_max_threads(),
              static_cast<long long>(s.env_steps), res.rate, t.env, t.inference, t.ppo, t.es, t.io, t.other, t.run_end, t.total, t.ppo_chunk_wait, t.es_chunk_wait,
              res.floor_rate, floor.ll_forward_s,
              floor.ll_train_s, floor.hl_forward_s, floor.hl_train_s,
              static_cast<long long>(floor.ll_forward_batch), static_cast<long long>(floor.ll_train_batch),
              static_cast<long long>(floor.hl_forward_batch), static_cast<long long>(floor.hl_train_batch),
              floor.ll_forward_alive, floor.ll_train_alive, floor.hl_forward_alive, floor.hl_train_alive, res.ratio,
              res.runs.size(), joined(res.rates, "%.6g").c_str(),
              joined(res.floor_rates, "%.6g").c_str(), joined(res.ratios, "%.4g").c_str(), joined(res.env_s, "%.4g").c_str(),
              joined(res.inference_s, "%.4g").c_str(), joined(res.ppo_s, "%.4g").c_str(), joined(res.es_s, "%.4g").c_str(),
              joined(res.io_s, "%.4g").c_str(), joined(res.ppo_chunk_wait_s, "%.4g").c_str(), joined(res.run_end_s, "%.4g").c_str(), io::json_string(io::cpu_model()).c_str(),
              io::json_string(io::blas_core()).c_str());
}

// A few lines for one config: the median rate, the median run's breakdown and its network floor.
void print_train_text(const std::string& path, const train::TrainConfig& cfg, const bench::TrainBenchResult& res) {
  const int n_agent = 2 * cfg.race.team_size;
  const bench::TrainBenchRun& mid = res.runs[res.median_run];
  const train::TrainSummary& s = mid.summary;
  const bench::NetworkFloor& floor = mid.floor;
  const auto& t = s.time;
  auto pct = [&](double x) { return 100.0 * x / t.per_update_loop(); };
  std::printf("%s: %d envs x %d aircraft, %lld env steps per run -> %.0f aircraft-steps/s end to end (median of "
              "%zu: %s)\n",
              path.c_str(), cfg.race.n_env, n_agent, static_cast<long long>(s.env_steps), res.rate, res.runs.size(),
              joined(res.rates, "%.0f").c_str());
  std::printf("  env (sim + race + obs) %.0f%%, inference %.0f%%, PPO updates %.0f%%, ES updates %.0f%%, "
              "I/O %.0f%%, other %.0f%%\n",
              pct(t.env), pct(t.inference), pct(t.ppo), pct(t.es), pct(t.io), pct(t.other));
  std::printf("  not counted: the wait for each run's last learning-curves figure, %s s (once per run of any "
              "length)\n",
              joined(res.run_end_s, "%.2f").c_str());
  // A slower core shows here: each step waits for its last chunk (agents::run_chunks).
  std::printf("  of the updates, beyond an even split of their concurrent chunks over the threads: PPO %.2f s "
              "(%.0f%% of PPO), ES %.2f s\n",
              t.ppo_chunk_wait, t.ppo > 0 ? 100.0 * t.ppo_chunk_wait / t.ppo : 0.0, t.es_chunk_wait);
  std::printf("  network floor %.0f aircraft-steps/s (end to end / floor: median %.2f, per run %s; each run priced "
              "at costs timed just before and after it)\n",
              res.floor_rate, res.ratio, joined(res.ratios, "%.2f").c_str());
  std::printf("  median run (%.1f s): %.0f aircraft-steps/s against its floor %.0f: %.1f s of network time at "
              "mean batches LL %lld / PPO %lld / HL %lld / ES %lld -- LL forward %.1f s, PPO %.1f s, HL forward "
              "%.1f s, ES %.1f s; other aircraft alive in those rows %.2f / %.2f / %.2f / %.2f, as in the random "
              "rows timed\n",
              t.per_update_loop(), mid.rate, mid.floor_rate, floor.total_s, static_cast<long long>(floor.ll_forward_batch),
              static_cast<long long>(floor.ll_train_batch), static_cast<long long>(floor.hl_forward_batch),
              static_cast<long long>(floor.hl_train_batch), floor.ll_forward_s, floor.ll_train_s,
              floor.hl_forward_s, floor.hl_train_s, floor.ll_forward_alive, floor.ll_train_alive,
              floor.hl_forward_alive, floor.hl_train_alive);
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
                "threads; %s, OpenBLAS kernels %s\n",
                o.repeat, o.updates, omp_get_max_threads(), io::cpu_model().c_str(),
                blas.empty() ? "- (not OpenBLAS)" : blas.c_str());
  }
  for (std::size_t c = 0; c < o.configs.size(); ++c) {
    const bench::TrainBenchResult res = bench::bench_training(configs[c], o.updates, o.repeat);
    if (o.json) print_train_json(o.configs[c], configs[c], res);
    else print_train_text(o.configs[c], configs[c], res);
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
