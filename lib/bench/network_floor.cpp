#include "bench/network_floor.hpp"

#include <omp.h>

#include <algorithm>

#include "agents/expected_sarsa.hpp"
#include "bench/network_cost.hpp"
#include "train/obs_views.hpp"

namespace f16race::bench {
namespace {

struct AliveShares {
  double ll_forward, ll_train, hl_forward, hl_train;
};

AliveShares alive_shares(const train::TrainConfig& cfg, const train::NetworkWork& w) {
  const std::int64_t n = train::obs_dims(cfg.race).n_other;
  return {alive_share(w.ll_forward_alive, w.ll_forward_rows, n), alive_share(w.ll_train_alive, w.ll_train_rows, n),
          alive_share(w.hl_forward_alive, w.hl_forward_rows, n), alive_share(w.hl_train_alive, w.hl_train_rows, n)};
}

// The chunks of one gradient step run concurrently on the OpenMP threads (PpoAgent::update,
// EsAgent::update): priced so, at most one per thread.
int concurrent_chunks(std::int64_t calls, std::int64_t steps) {
  const std::int64_t chunks_per_step = steps > 0 ? std::max<std::int64_t>(1, calls / steps) : 1;
  return static_cast<int>(std::min<std::int64_t>(omp_get_max_threads(), chunks_per_step));
}

}  // namespace

std::int64_t mean_batch(std::int64_t rows, std::int64_t calls) {
  return calls > 0 ? std::max<std::int64_t>(1, (rows + calls / 2) / calls) : 0;
}

double alive_share(std::int64_t alive, std::int64_t rows, std::int64_t n_other) {
  return rows > 0 && n_other > 0 ? static_cast<double>(alive) / static_cast<double>(rows * n_other) : kDefaultAliveShare;
}

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
  const int concurrent = concurrent_chunks(w.ll_train_calls, w.ll_train_steps);
  if (const std::int64_t b = mean_batch(w.ll_train_rows, w.ll_train_calls); b > 0)
    c.ll_train = measure_ll_cost(lc, b, kRepeats, false, concurrent, alive.ll_train, cfg.ll.fused_training)
                     .forward_backward_s;
  if (const std::int64_t b = mean_batch(w.hl_forward_rows, w.hl_forward_calls); b > 0)
    c.hl_forward = measure_hl_cost(hc, b, kRepeats, 1, cfg.hl.eigen_inference, alive.hl_forward).forward_s;
  // ES steps' chunks (hl.minibatch_chunks) run concurrently too.
  const int hl_concurrent = concurrent_chunks(w.hl_train_calls, w.hl_train_steps);
  if (const std::int64_t b = mean_batch(w.hl_train_rows, w.hl_train_calls); b > 0)
    c.hl_train = measure_hl_cost(hc, b, kRepeats, hl_concurrent, false, alive.hl_train, es_fused_training(cfg.hl))
                     .forward_backward_s;
  return c;
}

PhysicalFloor physical_floor(const train::TrainConfig& cfg, const train::NetworkWork& w, double fma_gflops) {
  models::LlActorCriticConfig lc = cfg.ll.net;
  lc.dims = train::obs_dims(cfg.race);
  agents::EsConfig ec = cfg.hl;
  ec.dims = lc.dims;
  if (ec.n_atoms > 1 && !(ec.v_max > ec.v_min)) ec.v_max = ec.v_min + 1.0;  // the support does not change the FLOPs
  const double ll = static_cast<double>(models::LlActorCritic(lc)->flops_per_sample());
  const double hl = static_cast<double>(models::HlCritic(agents::es_critic_config(ec))->flops_per_sample());
  PhysicalFloor f;
  f.flops = ll * (static_cast<double>(w.ll_forward_rows) + 3.0 * static_cast<double>(w.ll_train_rows)) +
            hl * (static_cast<double>(w.hl_forward_rows) + 3.0 * static_cast<double>(w.hl_train_rows));
  f.seconds = fma_gflops > 0.0 ? f.flops / (fma_gflops * 1e9) : 0.0;
  return f;
}

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

}  // namespace f16race::bench
