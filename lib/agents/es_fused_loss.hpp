#pragma once
// Expected SARSA's team losses on a chunk as single autograd nodes over plain loops (issue 13):
// each computes the loss, its statistics and the gradient with respect to the critic's output in
// one pass, where the composed LibTorch ops cost a dozen small ops and their backward nodes per
// chunk, plus three host reads. `es_loss` (agents/expected_sarsa.hpp) stays the oracle: tests hold
// each equal to it in value and gradient.
#include <torch/torch.h>

#include "agents/c51.hpp"

namespace f16race::agents {

// A chunk's teams for the losses' one pass on raw rows (what the nodes below compute, and the fused
// training pass calls directly): actions [T, n_a, 3] bins, active [T, n_a], target_value [T],
// target_dist [T, K] (ES+D3 only); the gradients are weight * d loss.
struct EsTeamRows {
  int64_t t = 0, n_a = 0, n_bins = 0;
  const int64_t* actions = nullptr;
  const bool* active = nullptr;
  const float* target_value = nullptr;
  const float* target_dist = nullptr;
  double weight = 1.0;
};

// Sums over the valid teams; the terms are each sum times inv_valid (1 / the valid teams, or 1).
struct EsLossSums {
  double loss = 0.0, q = 0.0, td = 0.0, inv_valid = 1.0;
};

// ES+D2 on q [T * n_a, 3, n_bins]: writes grad (same shape, zeros but at the taken bins).
EsLossSums es_d2_loss_rows(const EsTeamRows& rows, const float* q, double huber_delta, float* grad);
// ES+D3 on log_probs [T * n_a, 3, n_bins, K]: writes grad (same shape).
EsLossSums es_d3_loss_rows(const EsTeamRows& rows, const float* log_probs, const C51Support& support, float* grad);

struct FusedEsLoss {
  torch::Tensor total;  // weight * loss: scalar, differentiable with respect to the critic's output
  double loss = 0.0;    // unweighted: mean over valid teams
  double q = 0.0;       // mean over valid teams of es_loss's prediction
  double td = 0.0;      // mean over valid teams of |prediction - target_value|
};

// ES+D2 (the paper's Eq. 1 on the team): the Huber loss of the team's prediction, the mean over
// active members of the mean over axes of Q^{i,j}(a^{i,j}), to the team target.
// q [T * n_a, 3, n_bins] (the critic's), actions [T, n_a, 3] bins, active [T, n_a] bool,
// target_value [T]. A team counts when any member is active (es_loss's `valid`).
FusedEsLoss fused_es_d2_loss(const torch::Tensor& q, const torch::Tensor& actions, const torch::Tensor& active,
                             const torch::Tensor& target_value, double huber_delta, double weight = 1.0);

// ES+D3: the team mixture of the taken bins' atom distributions (a log-sum-exp per atom over active
// members and axes), its cross-entropy to the projected target, the masked mean over teams.
// log_probs [T * n_a, 3, n_bins, K] (the critic's), target_dist [T, K], the rest as above.
FusedEsLoss fused_es_d3_loss(const torch::Tensor& log_probs, const torch::Tensor& actions, const torch::Tensor& active,
                             const torch::Tensor& target_dist, const torch::Tensor& target_value,
                             const C51Support& support, double weight = 1.0);

}  // namespace f16race::agents
