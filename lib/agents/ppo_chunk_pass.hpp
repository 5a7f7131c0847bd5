#pragma once
// One chunk of a PPO minibatch through the low level's fused training pass: the actor-critic's
// forward and backward on plain buffers (models/kernels/attention_mlp_train.hpp) around the loss's
// one pass over the rows (ppo_loss_rows), instead of LibTorch's autograd graph of ~60 small ops.
// LibTorch's autograd through LlActorCritic::forward and fused_ppo_loss stays the oracle
// (PpoConfig::fused_training false; tests/agents/test_ppo_chunk_pass.cpp).
//
// One object per concurrent chunk; its scratch and gradient tensors are allocated on first use and
// reused, so a step allocates nothing.
#include <torch/torch.h>

#include <array>
#include <cstdint>
#include <vector>

#include "models/kernels/attention_mlp_train.hpp"
#include "models/ll_actor_critic.hpp"
#include "models/obs.hpp"

namespace f16race::agents {

// The chunk's samples: positions [m] into the update's valid rows; valid_rows [batch] the buffer row
// of each; actions [batch, A], old_log_probs, old_values, returns [batch] per valid row;
// advantages [m] the chunk's own, normalised. obs: the buffer's normalised observations, contiguous.
struct PpoChunkRows {
  const models::LlObs* obs = nullptr;
  int64_t m = 0;
  const int64_t* positions = nullptr;
  const int64_t* valid_rows = nullptr;
  const float *actions = nullptr, *old_log_probs = nullptr, *old_values = nullptr, *returns = nullptr;
  const float* advantages = nullptr;
};

// The loss's coefficients (PpoConfig's).
struct PpoLossCoefs {
  double clip = 0.2, vf_coef = 0.5, ent_coef = 0.0;
  bool clip_value = true;
};

class PpoChunkPass {
 public:
  // The gradients of weight x the chunk's loss with respect to every parameter of `net` into
  // grads() (parameters() order); returns the unweighted terms (policy, value, entropy, approx_kl,
  // clip_fraction). m >= 1.
  std::array<double, 5> run(const models::LlActorCriticImpl& net, const PpoChunkRows& rows, double weight,
                            const PpoLossCoefs& coefs);
  const std::vector<torch::Tensor>& grads() const { return grads_; }

 private:
  models::kernels::AttentionMlpTrain pass_;
  std::vector<int64_t> index_;
  std::vector<float> mean_, value_, d_mean_, d_value_, action_, old_log_prob_, old_value_, returns_;
  std::vector<double> d_log_std_;
  std::vector<torch::Tensor> grads_;
  models::kernels::AttentionMlpTrainGrads grad_views_;  // into grads_, made with them
  std::size_t log_std_slot_ = 0;                        // log_std's place in parameters()
};

}  // namespace f16race::agents
