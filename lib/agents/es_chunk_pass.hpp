#pragma once
// One chunk of an Expected SARSA minibatch (ES+D2 and ES+D3, the paper's team losses) through the
// high-level critic's fused training pass: the critic's forward and backward on plain buffers
// (models/kernels/attention_mlp_train.hpp), ES+D3's log-softmax over the atoms and its backward,
// around the loss's one pass over the teams (es_d2_loss_rows, es_d3_loss_rows). LibTorch's
// autograd through HlCritic::forward and the fused loss nodes stays the oracle
// (EsConfig::fused_training false; tests/agents/test_es_chunk_pass.cpp).
//
// One object per concurrent chunk; its scratch and gradient tensors are allocated on first use and
// reused.
#include <torch/torch.h>

#include <cstdint>
#include <memory>
#include <vector>

#include "agents/c51.hpp"
#include "agents/es_fused_loss.hpp"
#include "models/hl_critic.hpp"
#include "models/kernels/attention_mlp_train.hpp"
#include "models/obs.hpp"

namespace f16race::agents {

// The chunk's teams (indices into the batch's T teams) and the batch they come from: obs the
// normalised observations [T * n_a rows], contiguous; actions [T, n_a, 3] int64; active [T, n_a];
// target_value [T]; target_dist [T, K] (ES+D3; else null).
struct EsChunkRows {
  const models::HlObs* obs = nullptr;
  int64_t t = 0, n_a = 0;
  const int64_t* teams = nullptr;
  const int64_t* actions = nullptr;
  const bool* active = nullptr;
  const float* target_value = nullptr;
  const float* target_dist = nullptr;
};

class EsChunkPass {
 public:
  // The gradients of weight x the chunk's loss (ES+D2 when the critic has one atom, else ES+D3)
  // into grads() (parameters() order); returns the loss's sums. t >= 1.
  EsLossSums run(const models::HlCriticImpl& net, const EsChunkRows& rows, double weight, double huber_delta,
                 const C51Support& support);
  const std::vector<torch::Tensor>& grads() const { return grads_; }

 private:
  models::kernels::AttentionMlpTrain pass_;
  std::vector<int64_t> index_, actions_;
  std::unique_ptr<bool[]> active_;
  int64_t active_capacity_ = 0;
  std::vector<float> out_, log_probs_, d_log_probs_, d_out_, target_value_, target_dist_;
  std::vector<torch::Tensor> grads_;
  models::kernels::AttentionMlpTrainGrads grad_views_;  // into grads_, made with them
};

}  // namespace f16race::agents
