#include "bench/train_bench.hpp"

#include <omp.h>
#include <unistd.h>

#include <algorithm>
#include <filesystem>
#include <sstream>

#include "bench/fma_peak.hpp"
#include "bench/timing.hpp"

namespace f16race::bench {
namespace {

// Trains one run of `updates` in `dir` (emptied before and after) and returns its summary.
train::TrainSummary train_once(const train::TrainConfig& cfg, const std::string& dir, long long updates) {
  std::filesystem::remove_all(dir);
  train::TrainSummary s;
  {
    train::Trainer trainer(cfg, dir);
    s = trainer.run(nullptr, updates);
  }
  std::filesystem::remove_all(dir);
  return s;
}

// The per-run lists, the medians, and the median run by end-to-end rate.
void summarise(TrainBenchResult& r) {
  for (const TrainBenchRun& m : r.runs) {
    r.rates.push_back(m.rate);
    r.floor_rates.push_back(m.floor_rate);
    r.ratios.push_back(m.rate / m.floor_rate);
    r.env_s.push_back(m.summary.time.env);
    r.inference_s.push_back(m.summary.time.inference);
    r.ppo_s.push_back(m.summary.time.ppo);
    r.es_s.push_back(m.summary.time.es);
    r.io_s.push_back(m.summary.time.io);
    r.ppo_chunk_wait_s.push_back(m.summary.time.ppo_chunk_wait);
    r.run_end_s.push_back(m.summary.time.run_end);
  }
  std::vector<std::size_t> order(r.runs.size());
  for (std::size_t k = 0; k < order.size(); ++k) order[k] = k;
  std::sort(order.begin(), order.end(), [&](std::size_t a, std::size_t b) { return r.rates[a] < r.rates[b]; });
  r.median_run = order[order.size() / 2];
  r.rate = median_of(r.rates);
  r.floor_rate = median_of(r.floor_rates);
  r.ratio = median_of(r.ratios);
  std::vector<double> physical;
  for (const TrainBenchRun& m : r.runs) physical.push_back(m.physical_floor_rate);
  r.physical_floor_rate = median_of(physical);
}

}  // namespace

std::string scratch_run_dir() {
  return (std::filesystem::temp_directory_path() / ("f16race_bench_train." + std::to_string(::getpid()))).string();
}

TrainBenchResult bench_training(const train::TrainConfig& cfg, long long updates, int repeat) {
  const std::string dir = scratch_run_dir();
  const int n_agent = 2 * cfg.race.team_size;
  TrainBenchResult r;
  r.fma_gflops = measure_fma_peak(omp_get_max_threads(), 5).f32_gflops;
  FloorCosts previous;
  for (int k = 0; k < repeat; ++k) {
    TrainBenchRun m;
    m.summary = train_once(cfg, dir, updates);
    const FloorCosts costs = measure_floor_costs(cfg, m.summary.work);
    m.floor = price_floor(cfg, m.summary.work, k == 0 ? costs : previous, costs);
    previous = costs;
    // Per update, as a run of any length trains: without the wait for its last figure (run_end).
    m.rate = static_cast<double>(m.summary.env_steps) * n_agent / m.summary.time.per_update_loop();
    m.floor_rate = static_cast<double>(m.summary.env_steps) * n_agent / m.floor.total_s;
    m.physical = physical_floor(cfg, m.summary.work, r.fma_gflops);
    m.physical_floor_rate = static_cast<double>(m.summary.env_steps) * n_agent / m.physical.seconds;
    r.runs.push_back(std::move(m));
  }
  if (r.runs.size() > 1) r.runs.erase(r.runs.begin());
  summarise(r);
  return r;
}

std::string train_bench_fingerprint(long long updates, const std::vector<std::string>& configs,
                                    const std::vector<std::string>& overrides) {
  std::ostringstream fp;
  fp << "binary " << std::hex << dist::executable_hash() << std::dec << "\nbench train --updates " << updates;
  for (const std::string& c : configs) fp << "\n--config " << c;
  for (const std::string& v : overrides) fp << "\n--set " << v;
  return fp.str();
}

GroupTrainBench bench_training_in_group(const train::TrainConfig& cfg, long long updates, dist::Group& group) {
  const bool lead = group.rank() == 0;
  const std::string dir = scratch_run_dir();
  const int n_agent = 2 * cfg.race.team_size;
  if (lead) std::filesystem::remove_all(dir);
  double total_s = 0.0;
  std::vector<double> mine;
  GroupTrainBench g;
  {
    train::Trainer trainer(cfg, dir, &group);
    const train::TrainSummary s = trainer.run(nullptr, updates);
    total_s = s.time.per_update_loop();
    g.env_steps = s.env_steps;
    mine = {static_cast<double>(s.rank_env_steps) * n_agent / total_s, s.communication_s / total_s, total_s};
  }
  if (lead) std::filesystem::remove_all(dir);
  const std::vector<double> all = group.allgather(mine);
  g.slowest_s = total_s;
  for (int r = 0; r < group.size(); ++r) {
    g.slowest_s = std::max(g.slowest_s, all[3 * r + 2]);
    g.rank_rate.push_back(all[3 * r]);
    g.rank_communication_share.push_back(all[3 * r + 1]);
  }
  g.rate = static_cast<double>(g.env_steps) * n_agent / g.slowest_s;
  return g;
}

}  // namespace f16race::bench
