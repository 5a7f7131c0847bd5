#pragma once
// The Eigen copy of a network's weights that an agent's no-grad forwards run on (PPO's rollout
// actions and values, Expected SARSA's decisions), and the one rule for when it is copied again:
// when any parameter's storage or version counter moved since the last copy. LibTorch bumps the
// version on every in-place write (copy_, mul_, a load's set_, and clip_and_adam_step's kernel,
// which bumps it as LibTorch's own step would), so no caller has to say that the weights changed.
#include <torch/torch.h>

#include <cstdint>
#include <functional>
#include <utility>
#include <vector>

#include "models/kernels/attention_mlp_forward.hpp"

namespace f16race::agents {

class EigenMirror {
 public:
  using WeightsOf = std::function<models::AttentionMlpWeights()>;

  // Follows `params` (the network's parameter tensors, whose contents may change but which are
  // never replaced); `weights` gives the network's weights in AttentionMlpForward's layout.
  void follow(std::vector<torch::Tensor> params, WeightsOf weights);
  bool following() const { return static_cast<bool>(weights_); }

  // The forward on the weights as they are now (copied first if they changed; no allocation when
  // they did not). Throws std::logic_error before follow().
  models::AttentionMlpForward& current();

 private:
  std::vector<torch::Tensor> params_;
  WeightsOf weights_;
  std::vector<std::pair<const void*, std::uint32_t>> copied_;  // per parameter at the last copy; empty: none
  models::AttentionMlpForward forward_;
};

}  // namespace f16race::agents
