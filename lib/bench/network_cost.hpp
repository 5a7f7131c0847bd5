#pragma once
// Measured cost of the networks per aircraft sample at a given batch size, shared by
// `bench nets` (the table) and `bench train` (the network floor of a training run).
#include <torch/torch.h>

#include <cstdint>

#include "bench/timing.hpp"
#include "models/hl_critic.hpp"
#include "models/kernels/fixed_order_gemm.hpp"
#include "models/ll_actor_critic.hpp"
#include "models/obs.hpp"

namespace f16race::bench {

// Random observations of b samples: normal features, each other aircraft alive with probability
// `alive_share` (bench nets: 0.7; bench train: the share its run's rows had).
constexpr double kDefaultAliveShare = 0.7;
models::HlObs random_hl_obs(const models::ObsDims& dims, std::int64_t b, at::Generator& gen,
                            double alive_share = kDefaultAliveShare);

// Seconds per sample, medians: a no-grad forward, and a forward plus backward of the sum of the
// outputs (the network part of a PPO or ES minibatch step, without loss terms or optimiser).
struct SampleCost {
  double forward_s = 0.0;
  double forward_backward_s = 0.0;
};

// A sample cost at batch `batch`: each timed run repeats the call until it has seen about 8192
// samples, so small batches (one HL decision) are timed over many calls.
// LL options: `eigen_forward` prices the forward on the Eigen kernels (the rollout's, PpoConfig::eigen_inference);
// `concurrent` > 1 times that many forward+backward passes at once on the OpenMP threads, as
// PpoAgent::update runs the chunks of a minibatch (per-sample cost = wall time / all samples).
// `alive_share`: of the other aircraft in the random rows (the attention core skips the dead).
// `fused_train` prices the forward+backward on the fused training pass (PpoConfig::fused_training,
// models/kernels/attention_mlp_train.hpp), `concurrent` passes at once, one thread each; otherwise
// on LibTorch's autograd.
SampleCost measure_ll_cost(const models::LlActorCriticConfig& cfg, std::int64_t batch, int repeats,
                           bool eigen_forward = false, int concurrent = 1, double alive_share = kDefaultAliveShare,
                           bool fused_train = false);
// HL: `concurrent` as for the LL (EsAgent::update's chunks of a gradient step); `eigen_forward`
// prices the forward on the Eigen kernels (the decisions', EsConfig::eigen_inference);
// `fused_train` the forward+backward on the fused pass (EsConfig::fused_training: ES+D2, ES+D3).
SampleCost measure_hl_cost(const models::HlCriticConfig& cfg, std::int64_t batch, int repeats, int concurrent = 1,
                           bool eigen_forward = false, double alive_share = kDefaultAliveShare,
                           bool fused_train = false);

// GFLOP/s of a 1024 x 1024 x 1024 float matrix product at the current torch thread count: the
// peak this LibTorch build reaches on this machine, the reference for the networks' GFLOP/s.
double matmul_gflops(int repeats);

// GFLOP/s of one thread's fixed-order product (models/kernels/fixed_order_gemm.hpp) on a PPO
// chunk's first MLP layer, [459 x 101] x [101 x 64] with a bias, in the copy `isa`.
double fixed_order_gemm_gflops(models::kernels::GemmIsa isa, int repeats);

}  // namespace f16race::bench
