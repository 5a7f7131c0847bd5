#pragma once
// Data-parallel replicas of one learner (issue 18): every rank of a group holds the same
// networks, optimiser and normaliser, learns from its own samples, and the replicas meet here
// once per gradient step. An empty Replicas (the default) is a single process.
//
// What makes the replicas one learner: a gradient step is taken on the union of the ranks'
// minibatches (each rank's mean-loss gradient weighted by its share of the union's rows, summed),
// PPO's advantages are normalised over that union, and observation statistics absorb every
// rank's batch at once; each sum is the same bits on every rank, so the replicas stay equal.
#include <torch/torch.h>

#include <cstdint>
#include <functional>
#include <vector>

namespace f16race::agents {

struct Replicas {
  // Element-wise sums over the ranks, in place.
  std::function<void(float*, std::int64_t)> sum_floats;
  std::function<void(double*, std::int64_t)> sum_doubles;
  // Every rank's vector (the same length on each), concatenated in rank order.
  std::function<std::vector<double>(const std::vector<double>&)> gather;
  bool active() const { return static_cast<bool>(sum_floats); }
};

// One reduction for a gradient step of the replicas: every parameter's gradient becomes
// sum over ranks of weight x that rank's gradient (an undefined one counts as zeros), and `extra`
// (loss terms, counts: carried as float32) its sum over ranks.
void sum_weighted_gradients(const std::vector<torch::Tensor>& params, double weight, std::vector<double>& extra,
                            const Replicas& replicas);

}  // namespace f16race::agents
