// `f16race bench train`: end-to-end training throughput (aircraft LL steps per second including
// inference and both learners' updates) with a breakdown of where the time goes and the network
// floor (what the networks alone allow), for the default and the paper configuration shapes.
#include <omp.h>
#include <torch/torch.h>

#include <unistd.h>

#include <CLI/CLI.hpp>
#include <algorithm>
#include <cstdint>
#include <filesystem>
#include <memory>
#include <sstream>
#include <string>
#include <vector>

#include "commands.hpp"
#include "io/json_text.hpp"
#include "io/provenance.hpp"
#include "dist/process_group.hpp"
#include "dist_options.hpp"
#include "io/yaml_config.hpp"
#include "agents/expected_sarsa.hpp"
#include "network_cost.hpp"
#include "train/obs_views.hpp"
#include "train/trainer.hpp"

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

// The network floor: the run's network work (rows through each network, in calls of their mean
// batch) priced at per-sample costs measured here at those batches. Training cannot beat it
// without cheaper networks; end to end / floor says how much the rest (env, bookkeeping,
// losses, optimiser, copies) costs on top.
struct NetworkFloor {
  double ll_forward_s = 0, ll_train_s = 0, hl_forward_s = 0, hl_train_s = 0, total_s = 0;
  std::int64_t ll_forward_batch = 0, ll_train_batch = 0, hl_forward_batch = 0, hl_train_batch = 0;
  // Of the other aircraft in each part's rows, alive: the random rows the costs are timed on have it.
  double ll_forward_alive = 0, ll_train_alive = 0, hl_forward_alive = 0, hl_train_alive = 0;
};

// Seconds per row of each network part at the run's mean batches (medians of 5 timings).
struct FloorCosts {
  double ll_forward = 0, ll_train = 0, hl_forward = 0, hl_train = 0;
};

std::int64_t mean_batch(std::int64_t rows, std::int64_t calls) {
  return calls > 0 ? std::max<std::int64_t>(1, (rows + calls / 2) / calls) : 0;
}

// Alive share of the other aircraft over `rows` rows holding `alive` of them.
double alive_share(std::int64_t alive, std::int64_t rows, std::int64_t n_other) {
  return rows > 0 && n_other > 0 ? static_cast<double>(alive) / static_cast<double>(rows * n_other) : kDefaultAliveShare;
}

struct AliveShares {
  double ll_forward, ll_train, hl_forward, hl_train;
};

AliveShares alive_shares(const train::TrainConfig& cfg, const train::NetworkWork& w) {
  const std::int64_t n = train::obs_dims(cfg.race).n_other;
  return {alive_share(w.ll_forward_alive, w.ll_forward_rows, n), alive_share(w.ll_train_alive, w.ll_train_rows, n),
          alive_share(w.hl_forward_alive, w.hl_forward_rows, n), alive_share(w.hl_train_alive, w.hl_train_rows, n)};
}

// The costs are timed on random rows with the run's alive shares: the attention core skips the
// dead, and a run's rows (~0.9 alive at 32 envs) cost more than bench nets' 0.7.
FloorCosts measure_floor_costs(const train::TrainConfig& cfg, const train::NetworkWork& w) {
  constexpr int kRepeats = 5;
  const AliveShares alive = alive_shares(cfg, w);
  models::LlActorCriticConfig lc = cfg.ll.net;
  lc.dims = train::obs_dims(cfg.race);
  agents::EsConfig ec = cfg.hl;
  ec.dims = lc.dims;
  if (ec.n_atoms > 1 && !(ec.v_max > ec.v_min)) ec.v_max = ec.v_min + 1.0;  // the support does not change the cost
  const models::HlCriticConfig hc = agents::es_critic_config(ec);
  FloorCosts c;
  if (const std::int64_t b = mean_batch(w.ll_forward_rows, w.ll_forward_calls); b > 0)
    c.ll_forward = measure_ll_cost(lc, b, kRepeats, cfg.ll.eigen_inference, 1, alive.ll_forward).forward_s;
  // A minibatch's chunks run concurrently on the OpenMP threads (PpoAgent::update): priced so.
  const std::int64_t chunks_per_step = w.ll_train_steps > 0 ? std::max<std::int64_t>(1, w.ll_train_calls / w.ll_train_steps) : 1;
  const int concurrent = static_cast<int>(std::min<std::int64_t>(omp_get_max_threads(), chunks_per_step));
  if (const std::int64_t b = mean_batch(w.ll_train_rows, w.ll_train_calls); b > 0)
    c.ll_train = measure_ll_cost(lc, b, kRepeats, false, concurrent, alive.ll_train).forward_backward_s;
  if (const std::int64_t b = mean_batch(w.hl_forward_rows, w.hl_forward_calls); b > 0)
    c.hl_forward = measure_hl_cost(hc, b, kRepeats, 1, cfg.hl.eigen_inference, alive.hl_forward).forward_s;
  // ES steps' chunks (hl.minibatch_chunks) run concurrently too.
  const std::int64_t hl_chunks_per_step =
      w.hl_train_steps > 0 ? std::max<std::int64_t>(1, w.hl_train_calls / w.hl_train_steps) : 1;
  const int hl_concurrent = static_cast<int>(std::min<std::int64_t>(omp_get_max_threads(), hl_chunks_per_step));
  if (const std::int64_t b = mean_batch(w.hl_train_rows, w.hl_train_calls); b > 0)
    c.hl_train = measure_hl_cost(hc, b, kRepeats, hl_concurrent, false, alive.hl_train).forward_backward_s;
  return c;
}

// The run's work priced at the mean of two cost measurements, one before and one after it: the
// VM's speed drifts by tens of percent within minutes, so both sides of end to end / floor must
// see the same stretch of time.
NetworkFloor price_floor(const train::TrainConfig& cfg, const train::NetworkWork& w, const FloorCosts& before,
                         const FloorCosts& after) {
  NetworkFloor f;
  const AliveShares alive = alive_shares(cfg, w);
  f.ll_forward_alive = alive.ll_forward;
  f.ll_train_alive = alive.ll_train;
  f.hl_forward_alive = alive.hl_forward;
  f.hl_train_alive = alive.hl_train;
  f.ll_forward_batch = mean_batch(w.ll_forward_rows, w.ll_forward_calls);
  f.ll_train_batch = mean_batch(w.ll_train_rows, w.ll_train_calls);
  f.hl_forward_batch = mean_batch(w.hl_forward_rows, w.hl_forward_calls);
  f.hl_train_batch = mean_batch(w.hl_train_rows, w.hl_train_calls);
  f.ll_forward_s = w.ll_forward_rows * 0.5 * (before.ll_forward + after.ll_forward);
  f.ll_train_s = w.ll_train_rows * 0.5 * (before.ll_train + after.ll_train);
  f.hl_forward_s = w.hl_forward_rows * 0.5 * (before.hl_forward + after.hl_forward);
  f.hl_train_s = w.hl_train_rows * 0.5 * (before.hl_train + after.hl_train);
  f.total_s = f.ll_forward_s + f.ll_train_s + f.hl_forward_s + f.hl_train_s;
  return f;
}

// `bench train` as one rank of a group (started by --nproc through launch): the group trains one
// run; each rank reports its own throughput and its time inside collectives, rank 0 prints them.
// On one host the ranks share its cores, so this measures the cost of the group, not a speed-up.
void run_bench_train_rank(const TrainBenchOptions& o, const std::vector<train::TrainConfig>& configs,
                          const dist::DistConfig& dc) {
  torch::set_num_threads(omp_get_max_threads());
  std::ostringstream fp;
  fp << "binary " << std::hex << dist::executable_hash() << std::dec << "\nbench train --updates " << o.updates;
  for (const std::string& c : o.configs) fp << "\n--config " << c;
  for (const std::string& v : o.overrides) fp << "\n--set " << v;
  dist::Group group(dc, fp.str());
  const bool lead = group.rank() == 0;
  if (lead && !o.json)
    std::printf("f16race bench train: %lld updates per config, a group of %d ranks x %d threads on this host\n",
                o.updates, group.size(), omp_get_max_threads());
  for (std::size_t c = 0; c < o.configs.size(); ++c) {
    const std::string& path = o.configs[c];
    const train::TrainConfig& cfg = configs[c];
    const std::string dir =
        (std::filesystem::temp_directory_path() / ("f16race_bench_train." + std::to_string(::getpid()))).string();
    if (lead) std::filesystem::remove_all(dir);
    double total_s = 0.0;
    std::vector<double> mine;
    std::int64_t env_steps = 0;
    {
      train::Trainer trainer(cfg, dir, &group);
      const train::TrainSummary s = trainer.run(nullptr, o.updates);
      const int n_agent = 2 * cfg.race.team_size;
      total_s = s.time.per_update_loop();
      env_steps = s.env_steps;
      mine = {static_cast<double>(s.rank_env_steps) * n_agent / total_s, s.communication_s / total_s, total_s};
    }
    if (lead) std::filesystem::remove_all(dir);
    const std::vector<double> all = group.allgather(mine);
    if (!lead) continue;
    const int n_agent = 2 * cfg.race.team_size;
    double slowest = total_s;
    for (int r = 0; r < group.size(); ++r) slowest = std::max(slowest, all[3 * r + 2]);
    const double rate = static_cast<double>(env_steps) * n_agent / slowest;
    if (o.json) {
      std::string per_rank, comm;
      for (int r = 0; r < group.size(); ++r) {
        per_rank += (r ? ", " : "") + std::to_string(all[3 * r]);
        comm += (r ? ", " : "") + std::to_string(all[3 * r + 1]);
      }
      std::printf("{\"bench\": \"train\", \"config\": %s, \"envs\": %d, \"ranks\": %d, \"threads_per_rank\": %d, "
                  "\"aircraft_steps_per_s\": %.6g, \"per_rank_aircraft_steps_per_s\": [%s], "
                  "\"communication_share\": [%s]}\n",
                  io::json_string(path).c_str(), cfg.race.n_env, group.size(), omp_get_max_threads(), rate,
                  per_rank.c_str(), comm.c_str());
    } else {
      std::printf("%s: %d envs x %d aircraft over %d ranks, %lld env steps in %.1f s -> %.0f aircraft-steps/s for the "
                  "group\n",
                  path.c_str(), cfg.race.n_env, n_agent, group.size(), static_cast<long long>(env_steps), slowest, rate);
      for (int r = 0; r < group.size(); ++r)
        std::printf("  rank %d: %d envs, %.0f aircraft-steps/s, %.0f%% of its time in collectives\n", r,
                    cfg.race.n_env / group.size(), all[3 * r], 100.0 * all[3 * r + 1]);
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
                "threads; %s, OpenBLAS kernels %s\n",
                o.repeat, o.updates, omp_get_max_threads(), io::cpu_model().c_str(),
                blas.empty() ? "- (not OpenBLAS)" : blas.c_str());
  }
  for (std::size_t c = 0; c < o.configs.size(); ++c) {
    const std::string& path = o.configs[c];
    const train::TrainConfig& cfg = configs[c];
    // Per process, so two benches at once do not meet in one run folder.
    const std::string dir =
        (std::filesystem::temp_directory_path() / ("f16race_bench_train." + std::to_string(::getpid()))).string();
    const int n_agent = 2 * cfg.race.team_size;
    // Runs and floor timings alternate: run 1, costs 1, run 2, costs 2, ... Run k > 1 is priced
    // at the mean of costs k-1 and k (measured just before and just after it) and is warm; run 1
    // (cold start, one-sided floor) counts only when it is the only one.
    struct Measured {
      train::TrainSummary s;
      NetworkFloor floor;
      double rate = 0, floor_rate = 0;
    };
    std::vector<Measured> runs;
    FloorCosts previous;
    for (int k = 0; k < o.repeat; ++k) {
      std::filesystem::remove_all(dir);
      Measured m;
      {
        train::Trainer trainer(cfg, dir);
        m.s = trainer.run(nullptr, o.updates);
      }
      std::filesystem::remove_all(dir);
      const FloorCosts costs = measure_floor_costs(cfg, m.s.work);
      m.floor = price_floor(cfg, m.s.work, k == 0 ? costs : previous, costs);
      previous = costs;
      // Per update, as a run of any length trains: without the wait for its last figure (run_end).
      m.rate = static_cast<double>(m.s.env_steps) * n_agent / m.s.time.per_update_loop();
      m.floor_rate = static_cast<double>(m.s.env_steps) * n_agent / m.floor.total_s;
      runs.push_back(std::move(m));
    }
    if (runs.size() > 1) runs.erase(runs.begin());
    std::vector<double> rates, floor_rates, ratios, run_env, run_inference, run_ppo, run_es, run_io, run_ppo_wait, run_end;
    for (const Measured& m : runs) {
      rates.push_back(m.rate);
      floor_rates.push_back(m.floor_rate);
      ratios.push_back(m.rate / m.floor_rate);
      run_env.push_back(m.s.time.env);
      run_inference.push_back(m.s.time.inference);
      run_ppo.push_back(m.s.time.ppo);
      run_es.push_back(m.s.time.es);
      run_io.push_back(m.s.time.io);
      run_ppo_wait.push_back(m.s.time.ppo_chunk_wait);
      run_end.push_back(m.s.time.run_end);
    }
    // The breakdown is the median run's (by end-to-end rate).
    std::vector<std::size_t> order(runs.size());
    for (std::size_t k = 0; k < order.size(); ++k) order[k] = k;
    std::sort(order.begin(), order.end(), [&](std::size_t a, std::size_t b) { return rates[a] < rates[b]; });
    const Measured& mid = runs[order[order.size() / 2]];
    const train::TrainSummary& s = mid.s;
    const NetworkFloor& floor = mid.floor;
    const double rate = median_of(rates);
    const double floor_rate = median_of(floor_rates);
    const double ratio = median_of(ratios);
    const auto& t = s.time;
    const auto list = [](const std::vector<double>& v, const char* fmt) {
      std::string out;
      char buf[64];
      for (std::size_t k = 0; k < v.size(); ++k) {
        std::snprintf(buf, sizeof buf, fmt, v[k]);
        out += (k ? ", " : "") + std::string(buf);
      }
      return out;
    };
    if (o.json) {
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
                  static_cast<long long>(s.env_steps), rate, t.env, t.inference, t.ppo, t.es, t.io, t.other, t.run_end, t.total, t.ppo_chunk_wait, t.es_chunk_wait,
                  floor_rate, floor.ll_forward_s,
                  floor.ll_train_s, floor.hl_forward_s, floor.hl_train_s,
                  static_cast<long long>(floor.ll_forward_batch), static_cast<long long>(floor.ll_train_batch),
                  static_cast<long long>(floor.hl_forward_batch), static_cast<long long>(floor.hl_train_batch),
                  floor.ll_forward_alive, floor.ll_train_alive, floor.hl_forward_alive, floor.hl_train_alive, ratio,
                  runs.size(), list(rates, "%.6g").c_str(),
                  list(floor_rates, "%.6g").c_str(), list(ratios, "%.4g").c_str(), list(run_env, "%.4g").c_str(),
                  list(run_inference, "%.4g").c_str(), list(run_ppo, "%.4g").c_str(), list(run_es, "%.4g").c_str(),
                  list(run_io, "%.4g").c_str(), list(run_ppo_wait, "%.4g").c_str(), list(run_end, "%.4g").c_str(), io::json_string(io::cpu_model()).c_str(),
                  io::json_string(io::blas_core()).c_str());
    } else {
      auto pct = [&](double x) { return 100.0 * x / t.per_update_loop(); };
      std::printf("%s: %d envs x %d aircraft, %lld env steps per run -> %.0f aircraft-steps/s end to end (median of "
                  "%zu: %s)\n",
                  path.c_str(), cfg.race.n_env, n_agent, static_cast<long long>(s.env_steps), rate, runs.size(),
                  list(rates, "%.0f").c_str());
      std::printf("  env (sim + race + obs) %.0f%%, inference %.0f%%, PPO updates %.0f%%, ES updates %.0f%%, "
                  "I/O %.0f%%, other %.0f%%\n",
                  pct(t.env), pct(t.inference), pct(t.ppo), pct(t.es), pct(t.io), pct(t.other));
      std::printf("  not counted: the wait for each run's last learning-curves figure, %s s (once per run of any "
                  "length)\n",
                  list(run_end, "%.2f").c_str());
      // A slower core shows here: each step waits for its last chunk (agents::run_chunks).
      std::printf("  of the updates, beyond an even split of their concurrent chunks over the threads: PPO %.2f s "
                  "(%.0f%% of PPO), ES %.2f s\n",
                  t.ppo_chunk_wait, t.ppo > 0 ? 100.0 * t.ppo_chunk_wait / t.ppo : 0.0, t.es_chunk_wait);
      std::printf("  network floor %.0f aircraft-steps/s (end to end / floor: median %.2f, per run %s; each run priced "
                  "at costs timed just before and after it)\n",
                  floor_rate, ratio, list(ratios, "%.2f").c_str());
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
