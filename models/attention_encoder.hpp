#pragma once
// Multi-head cross-attention over the other aircraft (paper IV-B, after [56]): the ego features
// form the single query, each other aircraft's o_ado row is a key and a value. Dead aircraft
// are masked out, so the output depends only on the set of alive rows, not their order.
//
//   forward(ego [B, d_ego], ado [B, n_other, d_ado], ado_alive [B, n_other] bool)
//     -> [B, d_model]; exactly 0 for a row with no alive aircraft.
#include <torch/torch.h>

#include <vector>

#include "models/kernels/attention_mlp_forward.hpp"
#include "models/kernels/attention_mlp_train.hpp"
#include "models/obs.hpp"

namespace f16race::models {

// The masked multi-head attention core: q [B, H*dh] (one query per sample), k and v
// [B, N, H*dh], alive [B, N] bool -> [B, H*dh], softmax of q.k / sqrt(dh) over the alive keys of
// each head, exact zeros for a sample with nobody alive. One autograd node over plain-loop
// kernels (models/kernels/masked_attention.hpp).
torch::Tensor masked_attention(const torch::Tensor& q, const torch::Tensor& k, const torch::Tensor& v,
                               const torch::Tensor& alive, int64_t n_heads);
// The same composed of LibTorch ops (what the encoder used before): the test's reference.
torch::Tensor masked_attention_reference(const torch::Tensor& q, const torch::Tensor& k, const torch::Tensor& v,
                                         const torch::Tensor& alive, int64_t n_heads);

struct AttentionEncoderConfig {
  int64_t d_ego = 0;
  int64_t d_ado = 0;
  int64_t n_other = 0;
  int64_t d_model = 64;  // embedding width, split over the heads
  int64_t n_heads = 4;
};

class AttentionEncoderImpl : public torch::nn::Module {
 public:
  explicit AttentionEncoderImpl(const AttentionEncoderConfig& cfg);
  torch::Tensor forward(const torch::Tensor& ego, const torch::Tensor& ado, const torch::Tensor& ado_alive);
  int64_t output_dim() const { return cfg_.d_model; }
  const AttentionEncoderConfig& config() const { return cfg_; }
  // Floating-point operations of one sample's forward pass (a multiply-add counts 2; biases,
  // softmax and masking left out): the projections of ego and of every other aircraft, scores,
  // weighted sum, output projection. For `bench nets` / `bench train` GFLOP/s.
  int64_t flops_per_sample() const;

  // The projections, read by encoder_weights.
  const torch::nn::Linear& q_proj() const { return q_proj_; }
  const torch::nn::Linear& k_proj() const { return k_proj_; }
  const torch::nn::Linear& v_proj() const { return v_proj_; }
  const torch::nn::Linear& out_proj() const { return out_proj_; }

 private:
  AttentionEncoderConfig cfg_;
  torch::nn::Linear q_proj_{nullptr}, k_proj_{nullptr}, v_proj_{nullptr}, out_proj_{nullptr};
};
TORCH_MODULE(AttentionEncoder);

// Weights copied out of LibTorch modules for AttentionMlpForward (float, row-major).
DenseLayer dense_layer(const torch::nn::Linear& layer);
std::vector<DenseLayer> dense_layers(const torch::nn::Sequential& mlp);  // its Linear layers, in order
std::vector<torch::nn::Linear> linear_modules(const torch::nn::Sequential& mlp);  // the same, the modules
// The encoder's part of a network's AttentionMlpWeights: sizes (d_goal: the width of the input
// between ego and the encoding) and projections; the MLPs are the caller's.
AttentionMlpWeights encoder_weights(const AttentionEncoder& encoder, const ObsDims& dims);

// The same read in place for a training pass (models/kernels/attention_mlp_train.hpp): a layer's
// parameters, and the encoder's part of a network's AttentionMlpTrainNet, with d_goal the width
// between ego and the encoding (the LL's goal, the HL's previous action).
kernels::DenseView dense_view(const torch::nn::Linear& layer);
kernels::AttentionMlpTrainNet encoder_train_net(const AttentionEncoder& encoder, const ObsDims& dims, int64_t d_goal);
// Gradient views of `layer` in `grads`: one float tensor per parameter of `module`, in its
// parameters() order, each shaped and contiguous as its parameter.
kernels::DenseGradView dense_grad_view(const torch::nn::Module& module, const std::vector<torch::Tensor>& grads,
                                       const torch::nn::Linear& layer);
// The encoder's gradient views (q, k, v, out) of `module`'s `grads` as above; the MLPs' are the caller's.
kernels::AttentionMlpTrainGrads encoder_train_grads(const torch::nn::Module& module,
                                                    const std::vector<torch::Tensor>& grads,
                                                    const AttentionEncoder& encoder);

}  // namespace f16race::models
