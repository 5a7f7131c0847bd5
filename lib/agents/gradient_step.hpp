#pragma once
// The gradient step PPO and Expected SARSA share: a minibatch cut into chunks, each chunk's
// gradient computed concurrently (agents/concurrent_chunks.hpp), the chunks summed in chunk
// order (the same bits at any thread count), the replicas' gradients combined into the
// union's (agents/replicas.hpp), then the global norm clipped and Adam applied
// (agents/optimizer_step.hpp). The learners supply each chunk's loss and their weighting.
#include <torch/torch.h>

#include <array>
#include <cstdint>
#include <functional>
#include <vector>

#include "agents/replicas.hpp"

namespace f16race::agents {

inline constexpr int kMaxStepTerms = 5;  // loss terms a step reports (PPO's five)

// One chunk's part of a step. `weight` weighs its terms in the step's (its share of the
// minibatch: rows, or loss units); `grads` (one per parameter, already weighted, may be
// undefined or empty when the chunk has nothing to learn from) and `terms` are what run() fills.
struct ChunkGradient {
  double weight = 0.0;
  std::vector<torch::Tensor> grads;
  std::array<double, kMaxStepTerms> terms{};
};

// How the replicas' gradients become the union's.
enum class ReplicaMix {
  // `replica_weight` is this replica's share of the union's rows, known before the step: the
  // union's gradient and terms are the replicas' weighted sums.
  kShareWeighted,
  // `replica_weight` is this replica's count of loss units: the gradients and terms are summed
  // weighted by it, then divided by the union's count (no step when it is 0).
  kUnitMean,
};

struct GradientStepOptions {
  bool zero_unused = false;  // a parameter without a gradient in any chunk: zeros (else undefined)
  double max_grad_norm = 0.0;
  const Replicas* replicas = nullptr;  // inactive or null: one process
  ReplicaMix mix = ReplicaMix::kShareWeighted;
  double replica_weight = 1.0;
  int n_terms = kMaxStepTerms;  // the terms that cross the replicas
};

struct GradientStepResult {
  bool stepped = false;  // false: no replica had a unit (kUnitMean), no step anywhere
  std::array<double, kMaxStepTerms> terms{};  // sum over chunks of weight x terms (replicas: the union's)
  double grad_norm = 0.0;  // before clipping
  double chunk_wait_s = 0.0;  // run_chunks' wait (bench train)
  int64_t passes = 0;  // chunks that produced gradients
};

// run(c, &chunks[c]) for every chunk (concurrently when there are several); chunks[c].weight is
// set by the caller beforehand.
GradientStepResult gradient_step(torch::optim::Adam& optimizer, const std::vector<torch::Tensor>& params,
                                 std::vector<ChunkGradient>& chunks,
                                 const std::function<void(int64_t, ChunkGradient&)>& run,
                                 const GradientStepOptions& options);

}  // namespace f16race::agents
