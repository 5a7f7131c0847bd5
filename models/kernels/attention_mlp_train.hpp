#pragma once
// A network's training pass, the attention encoder and then MLPs on [ego, goal or prev_action,
// encoded, task], as one forward and one backward over plain buffers, instead of ~60 LibTorch ops
// and their autograd graph per chunk. Two networks have this shape (as for the rollout forward,
// attention_mlp_forward.hpp): the low-level actor-critic (models/ll_actor_critic.hpp: a tanh MLP
// for the action mean and one for the value) and the high-level critic (models/hl_critic.hpp: a
// ReLU trunk and its head as the one MLP, no value). The products are the
// fixed-order kernels (fixed_order_gemm.hpp), the attention core masked_attention.hpp's, tanh the
// rollout forward's (attention_mlp_forward.cpp), so the rollouts and the update see the same
// network to the bit. LibTorch's autograd through the modules' forward is the oracle
// (tests/models/test_attention_mlp_train.cpp).
//
// One object per concurrent chunk: it holds that chunk's activations between forward and backward,
// in scratch that grows to the largest chunk and is reused. Single-threaded: the caller runs
// chunks side by side (agents/concurrent_chunks.hpp), so the bits never depend on the threads.
// No LibTorch and no Eigen in this header (as attention_mlp_forward.hpp, for the same reason).
#include <cstdint>
#include <memory>
#include <vector>

namespace f16race::models::kernels {

// A Linear layer read in place: weight [out, in] row-major (LibTorch's layout), bias [out].
struct DenseView {
  int64_t out = 0, in = 0;
  const float* weight = nullptr;
  const float* bias = nullptr;
};

// Where a layer's gradients go (overwritten): weight [out, in], bias [out].
struct DenseGradView {
  float* weight = nullptr;
  float* bias = nullptr;
};

struct AttentionMlpTrainNet {
  // d_goal: the width between ego and the encoding (the LL's goal, the HL's previous action).
  int64_t d_ego = 0, d_goal = 0, d_ado = 0, n_other = 0, d_task = 0, d_model = 0, n_heads = 0;
  DenseView q, k, v, out;  // the encoder's projections
  // The output MLP (LL: the action mean; HL: trunk and head) and the value MLP ending in one unit
  // (LL only; empty: no value), `relu` or tanh between their layers.
  std::vector<DenseView> actor, critic;
  bool relu = false;
};

struct AttentionMlpTrainGrads {
  DenseGradView q, k, v, out;
  std::vector<DenseGradView> actor, critic;
};

// The chunk's rows, gathered from a buffer of normalised observations: ego [R, d_ego], goal
// [R, d_goal], ado [R, n_other, d_ado], ado_alive [R, n_other], task [R, d_task], all row-major
// and contiguous; index [B] the rows taken.
struct TrainRows {
  const float* ego = nullptr;
  const float* goal = nullptr;
  const float* ado = nullptr;
  const bool* ado_alive = nullptr;
  const float* task = nullptr;
  const int64_t* index = nullptr;
};

class AttentionMlpTrain {
 public:
  AttentionMlpTrain();
  ~AttentionMlpTrain();
  AttentionMlpTrain(const AttentionMlpTrain&) = delete;
  AttentionMlpTrain& operator=(const AttentionMlpTrain&) = delete;

  // Checks that the layers chain (throws std::invalid_argument naming the layer).
  static void check(const AttentionMlpTrainNet& net);
  // Writes mean [B, A] (the output MLP's) and value [B] (not without a value MLP) for `batch` rows
  // and keeps what backward needs.
  void forward(const AttentionMlpTrainNet& net, int64_t batch, const TrainRows& rows, float* mean, float* value);
  // The gradients of sum(d_mean * mean) + sum(d_value * value) for the last forward's rows, with
  // respect to every weight and bias of `net` (the same net as that forward; d_value unread
  // without a value MLP).
  void backward(const AttentionMlpTrainNet& net, const float* d_mean, const float* d_value,
                const AttentionMlpTrainGrads& grads);

 private:
  struct Impl;
  std::unique_ptr<Impl> impl_;
};

}  // namespace f16race::models::kernels
