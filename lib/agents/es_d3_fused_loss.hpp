#pragma once
// ES+D3's loss on a chunk as one autograd node over plain loops (issue 13): the team mixture of
// the taken bins' atom distributions (a log-sum-exp per atom over active members and axes), its
// cross-entropy to the projected target, and the masked mean over teams, with the gradient with
// respect to the critic's log-probabilities from the same pass. `es_loss` (agents/expected_sarsa.hpp)
// stays the oracle: a test holds the two equal in value and gradient.
#include <torch/torch.h>

#include "agents/c51.hpp"

namespace f16race::agents {

struct FusedEsD3Loss {
  torch::Tensor total;  // weight * loss: scalar, differentiable with respect to log_probs
  double loss = 0.0;    // unweighted: mean over valid teams of the cross-entropy
  double q = 0.0;       // mean over valid teams of the mixture's expected return (es_loss's prediction)
  double td = 0.0;      // mean over valid teams of |prediction - target_value|
};

// log_probs [T * n_a, 3, n_bins, K] (the critic's), actions [T, n_a, 3] bins, active [T, n_a] bool,
// target_dist [T, K], target_value [T]. A team counts when any member is active (es_loss's `valid`).
FusedEsD3Loss fused_es_d3_loss(const torch::Tensor& log_probs, const torch::Tensor& actions,
                               const torch::Tensor& active, const torch::Tensor& target_dist,
                               const torch::Tensor& target_value, const C51Support& support, double weight = 1.0);

}  // namespace f16race::agents
