#include "bench/train_bench_report.hpp"

#include <omp.h>

#include <cstdarg>
#include <cstdio>

#include "io/json_text.hpp"
#include "io/numeric_mode.hpp"
#include "io/provenance.hpp"

namespace f16race::bench {
namespace {

// printf onto the end of `out`.
void appendf(std::string& out, const char* fmt, ...) {
  va_list args, again;
  va_start(args, fmt);
  va_copy(again, args);
  const int n = std::vsnprintf(nullptr, 0, fmt, args);
  va_end(args);
  if (n > 0) {
    const std::size_t at = out.size();
    out.resize(at + static_cast<std::size_t>(n) + 1);
    std::vsnprintf(&out[at], static_cast<std::size_t>(n) + 1, fmt, again);
    out.resize(at + static_cast<std::size_t>(n));
  }
  va_end(again);
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

}  // namespace

// One JSON object for one config: the medians, the median run's breakdown and floor, every run's figures.
std::string train_bench_json(const std::string& path, const train::TrainConfig& cfg, const TrainBenchResult& res) {
  std::string out;
  const int n_agent = 2 * cfg.race.team_size;
  const TrainBenchRun& mid = res.runs[res.median_run];
  const train::TrainSummary& s = mid.summary;
  const NetworkFloor& floor = mid.floor;
  const auto& t = s.time;
  appendf(out, "{\"bench\": \"train\", \"config\": %s, \"envs\": %d, \"aircraft\": %d, \"threads\": %d, "
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
              "\"cpu\": %s, \"blas_core\": %s, \"numerics\": %s, ",
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
              io::json_string(io::blas_core()).c_str(), io::json_string(io::numeric_mode_name()).c_str());
  // The physical floor: the median run's network FLOPs at the CPU's float FMA peak.
  const double physical_ratio = res.physical_floor_rate > 0 ? res.rate / res.physical_floor_rate : 0.0;
  appendf(out, "\"fma_peak_gflops\": %.6g, \"network_gflop\": %.6g, \"physical_floor_aircraft_steps_per_s\": %.6g, "
               "\"physical_floor_ratio\": %.4g}\n",
          res.fma_gflops, mid.physical.flops * 1e-9, res.physical_floor_rate, physical_ratio);
  return out;
}

// A few lines for one config: the median rate, the median run's breakdown and its network floor.
std::string train_bench_text(const std::string& path, const train::TrainConfig& cfg, const TrainBenchResult& res) {
  std::string out;
  const int n_agent = 2 * cfg.race.team_size;
  const TrainBenchRun& mid = res.runs[res.median_run];
  const train::TrainSummary& s = mid.summary;
  const NetworkFloor& floor = mid.floor;
  const auto& t = s.time;
  auto pct = [&](double x) { return 100.0 * x / t.per_update_loop(); };
  appendf(out, "%s: %d envs x %d aircraft, %lld env steps per run -> %.0f aircraft-steps/s end to end (median of "
              "%zu: %s)\n",
              path.c_str(), cfg.race.n_env, n_agent, static_cast<long long>(s.env_steps), res.rate, res.runs.size(),
              joined(res.rates, "%.0f").c_str());
  appendf(out, "  env (sim + race + obs) %.0f%%, inference %.0f%%, PPO updates %.0f%%, ES updates %.0f%%, "
              "I/O %.0f%%, other %.0f%%\n",
              pct(t.env), pct(t.inference), pct(t.ppo), pct(t.es), pct(t.io), pct(t.other));
  appendf(out, "  not counted: the wait for each run's last learning-curves figure, %s s (once per run of any "
              "length)\n",
              joined(res.run_end_s, "%.2f").c_str());
  // A slower core shows here: each step waits for its last chunk (agents::run_chunks).
  appendf(out, "  of the updates, beyond an even split of their concurrent chunks over the threads: PPO %.2f s "
              "(%.0f%% of PPO), ES %.2f s\n",
              t.ppo_chunk_wait, t.ppo > 0 ? 100.0 * t.ppo_chunk_wait / t.ppo : 0.0, t.es_chunk_wait);
  appendf(out, "  network floor %.0f aircraft-steps/s (end to end / floor: median %.2f, per run %s; each run priced "
              "at costs timed just before and after it)\n",
              res.floor_rate, res.ratio, joined(res.ratios, "%.2f").c_str());
  appendf(out, "  median run (%.1f s): %.0f aircraft-steps/s against its floor %.0f: %.1f s of network time at "
              "mean batches LL %lld / PPO %lld / HL %lld / ES %lld -- LL forward %.1f s, PPO %.1f s, HL forward "
              "%.1f s, ES %.1f s; other aircraft alive in those rows %.2f / %.2f / %.2f / %.2f, as in the random "
              "rows timed\n",
              t.per_update_loop(), mid.rate, mid.floor_rate, floor.total_s, static_cast<long long>(floor.ll_forward_batch),
              static_cast<long long>(floor.ll_train_batch), static_cast<long long>(floor.hl_forward_batch),
              static_cast<long long>(floor.hl_train_batch), floor.ll_forward_s, floor.ll_train_s,
              floor.hl_forward_s, floor.hl_train_s, floor.ll_forward_alive, floor.ll_train_alive,
              floor.hl_forward_alive, floor.hl_train_alive);
  appendf(out, "  physical floor %.0f aircraft-steps/s: the median run's %.1f GFLOP of networks at the CPU's float "
              "FMA peak, %.0f GFLOP/s (end to end / physical floor %.3f; the kernel-priced floor above is %.3f of "
              "it)\n",
          res.physical_floor_rate, mid.physical.flops * 1e-9, res.fma_gflops,
          res.physical_floor_rate > 0 ? res.rate / res.physical_floor_rate : 0.0,
          res.physical_floor_rate > 0 ? res.floor_rate / res.physical_floor_rate : 0.0);
  return out;
}


}  // namespace f16race::bench
