#pragma once
// The network floor of a training run (`bench train`): the run's network work (rows through each
// network, in calls of their mean batch) priced at per-sample costs measured at those batches.
// Training cannot beat it without cheaper networks; end to end / floor says how much the rest
// (env, bookkeeping, losses, optimiser, copies) costs on top.
#include <cstdint>

#include "train/train_config.hpp"
#include "train/trainer.hpp"

namespace f16race::bench {

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

// rows / calls rounded to the nearest (at least 1); 0 without calls.
std::int64_t mean_batch(std::int64_t rows, std::int64_t calls);
// Alive share of the other aircraft over `rows` rows holding `alive` of them (bench nets' 0.7
// without rows).
double alive_share(std::int64_t alive, std::int64_t rows, std::int64_t n_other);

// The costs are timed on random rows with the run's alive shares: the attention core skips the
// dead, and a run's rows (~0.9 alive at 32 envs) cost more than bench nets' 0.7.
FloorCosts measure_floor_costs(const train::TrainConfig& cfg, const train::NetworkWork& w);

// The run's work priced at the mean of two cost measurements, one before and one after it: the
// VM's speed drifts by tens of percent within minutes, so both sides of end to end / floor must
// see the same stretch of time.
NetworkFloor price_floor(const train::TrainConfig& cfg, const train::NetworkWork& w, const FloorCosts& before,
                         const FloorCosts& after);

// The run's network FLOPs (no-grad rows at a forward's FLOPs, training rows at three: the
// backward counted as twice the forward) and the seconds they take at the CPU's float FMA peak:
// the physical floor, which no kernel beats (the dead aircraft the attention core skips counted as
// work, so it is lower still).
struct PhysicalFloor {
  double flops = 0.0;
  double seconds = 0.0;
};
PhysicalFloor physical_floor(const train::TrainConfig& cfg, const train::NetworkWork& w, double fma_gflops);

}  // namespace f16race::bench
