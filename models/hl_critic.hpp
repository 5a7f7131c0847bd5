#pragma once
// High-level critic (paper III-C a, IV-B): attention encoder + two-layer MLP on
// [ego, prev_action, encoded ado, task], then one of two heads:
//   decoupled (es_d1, es_d2, es_d3): per action dimension j in {n, e, a} and bin b, a utility
//     Q^j(o, b) (n_atoms == 1) or a categorical over n_atoms return atoms (C51, n_atoms > 1);
//   joint (es): one value per joint action a = b_n * n_bins^2 + b_e * n_bins + b_a.
// The decoupled heads share one encoder and trunk (the paper's reading).
//
//   forward(HlObs with batch B) -> HlOutput
//     q          decoupled: [B, 3, n_bins]        joint: [B, n_bins^3]
//                (n_atoms > 1: expectation sum_k z_k p_k of the categorical)
//     log_probs  n_atoms > 1 only: decoupled [B, 3, n_bins, n_atoms], joint [B, n_bins^3, n_atoms]
//                (log-softmax over atoms); undefined when n_atoms == 1.
#include <torch/torch.h>

#include <vector>

#include "models/attention_encoder.hpp"
#include "models/obs.hpp"

namespace f16race::models {

struct HlCriticConfig {
  ObsDims dims;
  int64_t d_model = 64;  // attention encoder width
  int64_t n_heads = 4;
  std::vector<int64_t> hidden{64, 64};  // paper Table I h_dim
  bool decoupled = true;
  int64_t n_bins = 7;   // paper Table I n_ES,bin
  int64_t n_atoms = 1;  // 51 for the distributional critic (C51)
  double v_min = -10.0;  // atom support, used when n_atoms > 1
  double v_max = 10.0;
};

struct HlOutput {
  torch::Tensor q;
  torch::Tensor log_probs;
};

class HlCriticImpl : public torch::nn::Module {
 public:
  explicit HlCriticImpl(const HlCriticConfig& cfg);
  // with_q false (n_atoms > 1): log_probs only, q left undefined; a loss that reads only the
  // distribution (the fused ES+D3 loss) skips q's exp, product and sum and their graph nodes.
  HlOutput forward(const HlObs& obs, bool with_q = true);
  const HlCriticConfig& config() const { return cfg_; }
  int64_t n_joint_actions() const { return cfg_.n_bins * cfg_.n_bins * cfg_.n_bins; }
  // Forward FLOPs of one sample (encoder, trunk, head; see AttentionEncoderImpl::flops_per_sample).
  int64_t flops_per_sample() const;
  // Atom values z_k = v_min + k (v_max - v_min) / (K - 1), [n_atoms] (a buffer, saved with the net).
  const torch::Tensor& atoms() const { return atoms_; }
  // The last step of forward(): q (and log_probs) from the heads' output [B, head_width()]
  // (axis-major, atoms innermost), for an output computed elsewhere (AttentionMlpForward).
  HlOutput from_head(const torch::Tensor& out, bool with_q = true) const;
  int64_t head_width() const;
  // The network as AttentionMlpForward runs it (ReLU trunk and head as its one MLP).
  AttentionMlpWeights eigen_weights() const;
  // The same read in place for the fused training pass (models/kernels/attention_mlp_train.hpp):
  // its output is the head's [B, head_width()]; valid while the parameters' storage is.
  kernels::AttentionMlpTrainNet train_net() const;
  // Gradient views into `grads`, one float tensor per parameter in parameters() order.
  kernels::AttentionMlpTrainGrads train_grads(const std::vector<torch::Tensor>& grads) const;

 private:
  HlCriticConfig cfg_;
  // Modules "encoder", "trunk", "head": the names every checkpoint holds.
  AttentionEncoder encoder_{nullptr};
  torch::nn::Sequential trunk_{nullptr};
  torch::nn::Linear head_{nullptr};
  torch::Tensor atoms_;
};
TORCH_MODULE(HlCritic);

}  // namespace f16race::models
