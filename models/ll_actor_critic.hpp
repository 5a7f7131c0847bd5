#pragma once
// Low-level goal-conditioned actor-critic (paper III-C b, IV-B): a shared attention encoder,
// then separate two-layer tanh MLPs for the actor and the critic, each on
// [ego, goal, encoded ado, task]. Gaussian policy with a state-independent learnable log-std.
// Actions are in normalised units; the environment clips and scales them.
//
//   forward(LlObs with batch B) -> LlOutput
//     mean     [B, action_dim]
//     log_std  [B, action_dim]   (the learnable [action_dim] vector, expanded)
//     value    [B]
#include <torch/torch.h>

#include <vector>

#include "models/attention_encoder.hpp"
#include "models/kernels/attention_mlp_forward.hpp"
#include "models/kernels/attention_mlp_train.hpp"
#include "models/obs.hpp"

namespace f16race::models {

struct LlActorCriticConfig {
  ObsDims dims;
  int64_t action_dim = 3;  // [throttle, Nz_ref, ps_ref]
  int64_t d_model = 64;
  int64_t n_heads = 4;
  std::vector<int64_t> hidden{64, 64};  // paper Table I h_dim, for actor and critic each
  double init_log_std = 0.0;
};

struct LlOutput {
  torch::Tensor mean, log_std, value;
};

class LlActorCriticImpl : public torch::nn::Module {
 public:
  explicit LlActorCriticImpl(const LlActorCriticConfig& cfg);
  LlOutput forward(const LlObs& obs);
  const LlActorCriticConfig& config() const { return cfg_; }
  // Forward FLOPs of one sample (encoder, actor and critic; see AttentionEncoderImpl::flops_per_sample).
  int64_t flops_per_sample() const;
  // A float copy of the weights for AttentionMlpForward (no-grad inference without LibTorch ops).
  AttentionMlpWeights eigen_weights() const;
  const torch::Tensor& log_std() const { return log_std_; }  // [action_dim]
  // The weights in place for the fused training pass (models/kernels/attention_mlp_train.hpp): valid
  // while the parameters' storage is (the optimiser updates it in place).
  kernels::AttentionMlpTrainNet train_net() const;
  // Gradient views into `grads`, one float tensor per parameter in parameters() order, each shaped
  // and contiguous as its parameter (log_std's is the caller's).
  kernels::AttentionMlpTrainGrads train_grads(const std::vector<torch::Tensor>& grads) const;

 private:
  LlActorCriticConfig cfg_;
  AttentionEncoder encoder_{nullptr};
  torch::nn::Sequential actor_{nullptr}, critic_{nullptr};
  torch::Tensor log_std_;
};
TORCH_MODULE(LlActorCritic);

// Diagonal Gaussian log-density summed over the action dimensions: [B, A] x3 -> [B].
torch::Tensor gaussian_log_prob(const torch::Tensor& mean, const torch::Tensor& log_std, const torch::Tensor& action);
// Diagonal Gaussian entropy summed over the action dimensions: [B, A] -> [B].
torch::Tensor gaussian_entropy(const torch::Tensor& log_std);

}  // namespace f16race::models
