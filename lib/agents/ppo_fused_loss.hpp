#pragma once
// PPO's clipped loss on a chunk as one autograd node over plain loops (issue 13): the Gaussian
// log-probability, ratio, clipped surrogate, clipped value loss and entropy of `ppo_loss` in one
// pass, their derivatives with respect to the network's outputs computed in the same pass. The
// composed LibTorch version (agents/ppo.hpp: gaussian_log_prob + gaussian_entropy + ppo_loss)
// stays the oracle: a test holds the two equal in value and gradient.
#include <torch/torch.h>

#include <array>

#include "agents/ppo.hpp"

namespace f16race::agents {

// The loss of `ppo_loss_rows` on raw rows: the network's outputs mean [M, A], log_std (row i at
// log_std + i * log_std_row_stride: 0 for the one [A] parameter), value [M]; the constants action
// [M, A], old_log_prob, advantages (normalised), old_value, returns [M]. M >= 1.
struct PpoLossRows {
  int64_t m = 0, a_dim = 0;
  const float *mean = nullptr, *log_std = nullptr;
  int64_t log_std_row_stride = 0;
  const float *value = nullptr, *action = nullptr, *old_log_prob = nullptr, *advantages = nullptr,
              *old_value = nullptr, *returns = nullptr;
  double clip = 0.2, vf_coef = 0.5, ent_coef = 0.0, weight = 1.0;
  bool clip_value = true;
};

// d(weight * total)/d(output): d_mean [M, A], d_value [M]; for log_std per row (d_log_std [M, A])
// and/or summed over the rows in double (d_log_std_sum [A]), either may be null.
struct PpoLossGrads {
  float *d_mean = nullptr, *d_log_std = nullptr, *d_value = nullptr;
  double* d_log_std_sum = nullptr;
};

// One pass over the rows: writes the gradients, returns the unweighted terms (policy, value,
// entropy, approx_kl, clip_fraction). What fused_ppo_loss's node computes, and the fused training
// pass (PpoAgent) calls directly.
std::array<double, 5> ppo_loss_rows(const PpoLossRows& in, const PpoLossGrads& out);

struct FusedPpoLoss {
  torch::Tensor total;  // weight * (policy - ent_coef entropy + vf_coef value): scalar, differentiable
                        // with respect to mean, log_std and value
  // The chunk's terms, unweighted, as ppo_loss defines them.
  double policy_loss = 0.0, value_loss = 0.0, entropy = 0.0, approx_kl = 0.0, clip_fraction = 0.0;
};

// mean, log_std [M, A] (log_std may be an expanded view of one [A] parameter), value [M]: the
// network's outputs; action [M, A], old_log_prob, advantages (already normalised: the config's
// normalize_advantages must be off), old_value, returns [M]: constants. M >= 1.
FusedPpoLoss fused_ppo_loss(const torch::Tensor& mean, const torch::Tensor& log_std, const torch::Tensor& value,
                            const torch::Tensor& action, const torch::Tensor& old_log_prob,
                            const torch::Tensor& advantages, const torch::Tensor& old_value,
                            const torch::Tensor& returns, const PpoConfig& cfg, double weight = 1.0);

}  // namespace f16race::agents
