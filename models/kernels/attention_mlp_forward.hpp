#pragma once
// The forward pass of an attention encoder followed by MLPs on [ego, goal or prev_action, encoded,
// task], for no-grad inference on plain float kernels instead of LibTorch ops, with the weights
// copied out of the LibTorch module. Two networks have this shape: the low-level actor-critic
// (tanh MLPs for the action mean and the value; models/ll_actor_critic.hpp) and the high-level
// critic with one shared branch (a ReLU trunk and its head, no value MLP; models/hl_critic.hpp).
// At rollout batch sizes (a few to hundreds of rows) LibTorch spends more time per call in
// dispatch and allocation of ~30 small ops than in arithmetic; this does the same arithmetic in a
// handful of matrix products (the training path's fixed-order kernels, fixed_order_gemm.hpp) and
// plain loops over preallocated Eigen scratch. Held equal to LlActorCritic::forward
// and HlCritic::forward by tests/models/test_attention_mlp_forward.
//
// No Eigen type crosses this header: the kernels are compiled with the simulator's instruction-set
// flags (AVX-512 where there is one), which change Eigen's alignment and allocation scheme, so an
// Eigen object made in a LibTorch translation unit and freed here would corrupt the heap.
#include <cstdint>
#include <memory>
#include <vector>

#include "models/kernels/normalize_row.hpp"

namespace f16race::models {

// One Linear layer: y = x W^T + b.
struct DenseLayer {
  int64_t out = 0, in = 0;
  std::vector<float> weight;  // [out, in], row-major (LibTorch's layout)
  std::vector<float> bias;    // [out]
};

// Between an MLP's layers (none after its last).
enum class Activation { kTanh, kRelu };

struct AttentionMlpWeights {
  int64_t d_ego = 0, d_goal = 0, d_ado = 0, n_other = 0, d_task = 0, d_model = 0, n_heads = 0;
  DenseLayer q, k, v, out;  // attention encoder projections
  // The output MLP (LL: the action mean; HL: trunk and head) and the value MLP ending in one unit
  // (LL only; empty: no value).
  std::vector<DenseLayer> mlp, value_mlp;
  Activation activation = Activation::kTanh;
};

// The Gaussian policy's draw for each row, done by the block that computed the row's mean:
// action = mean + noise * std and its log-probability, with LibTorch's float arithmetic in its
// order (PpoAgent::act's torch ops are the oracle: models::gaussian_log_prob).
struct GaussianDraw {
  const float* noise = nullptr;    // [B, A] standard normal
  const float* std = nullptr;      // [A] exp(log_std)
  const float* inv_std = nullptr;  // [A] exp(-log_std)
  const float* log_std = nullptr;  // [A]
  float* action = nullptr;         // [B, A]
  float* log_prob = nullptr;       // [B]
};

// Raw observations and the statistics that normalise them, for a forward that normalises its
// rows in its blocks on the threads (RunningNorm's arithmetic, kernels::normalize_row) and hands
// the normalised rows back: what ObsNormalizer::normalize(obs, rows) and forward() do one after the
// other, the same bits, without the serial pass and its tensors between them.
struct LlRawRows {
  // Raw, row-major and contiguous over all rows of the batch they come from: ego [N, d_ego], goal
  // [N, d_goal], ado [N, n_other, d_ado], ado_alive [N, n_other], task [N, d_task].
  const float* ego = nullptr;
  const float* goal = nullptr;
  const float* ado = nullptr;
  const bool* ado_alive = nullptr;
  const float* task = nullptr;
  const int64_t* index = nullptr;  // [B] the rows taken, in [0, N); nullptr: rows 0..B-1
  kernels::NormTerms ego_norm, goal_norm, ado_norm, task_norm;
  // The B normalised rows, written (a dead aircraft's ado row is zeros): ego [B, d_ego], goal
  // [B, d_goal], ado [B, n_other, d_ado], ado_alive [B, n_other], task [B, d_task].
  float* ego_out = nullptr;
  float* goal_out = nullptr;
  float* ado_out = nullptr;
  bool* ado_alive_out = nullptr;
  float* task_out = nullptr;
};

class AttentionMlpForward {
 public:
  AttentionMlpForward();
  ~AttentionMlpForward();
  AttentionMlpForward(const AttentionMlpForward&) = delete;
  AttentionMlpForward& operator=(const AttentionMlpForward&) = delete;

  // Takes the weights; checks that the layer shapes chain (throws std::invalid_argument and keeps
  // the previous weights).
  void set_weights(const AttentionMlpWeights& weights);
  bool ready() const;

  // Normalised observations, row-major and contiguous: ego [B, d_ego], goal [B, d_goal],
  // ado [B, n_other, d_ado], ado_alive [B, n_other], task [B, d_task]. Writes mean [B, A] (the
  // output MLP's) and value [B] (the value MLP's; not with none, or value null). Scratch grows to
  // the largest B seen and is reused.
  // With `draw`, each block also samples its rows' actions (see GaussianDraw).
  void forward(int64_t batch, const float* ego, const float* goal, const float* ado, const bool* ado_alive,
               const float* task, float* mean, float* value, const GaussianDraw* draw = nullptr);
  // The same on B raw rows: each block normalises its rows into `raw`'s outputs first.
  void forward(int64_t batch, const LlRawRows& raw, float* mean, float* value, const GaussianDraw* draw = nullptr);

 private:
  // Both forwards: the blocks over the threads, each normalising its rows first when raw is given
  // (the other pointers then are raw's outputs).
  void run_blocks(int64_t batch, const LlRawRows* raw, const float* ego, const float* goal, const float* ado,
                  const bool* ado_alive, const float* task, float* mean, float* value, const GaussianDraw* draw);
  struct Impl;  // Eigen weights and scratch, made and freed only in attention_mlp_forward.cpp
  std::unique_ptr<Impl> impl_;
};

}  // namespace f16race::models
