#pragma once
// PPO's clipped loss on a chunk as one autograd node over plain loops (issue 13): the Gaussian
// log-probability, ratio, clipped surrogate, clipped value loss and entropy of `ppo_loss` in one
// pass, their derivatives with respect to the network's outputs computed in the same pass. The
// composed LibTorch version (agents/ppo.hpp: gaussian_log_prob + gaussian_entropy + ppo_loss)
// stays the oracle: a test holds the two equal in value and gradient.
#include <torch/torch.h>

#include "agents/ppo.hpp"

namespace f16race::agents {

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
