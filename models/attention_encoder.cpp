#include "models/attention_encoder.hpp"

#include <cmath>

namespace f16race::models {

AttentionEncoderImpl::AttentionEncoderImpl(const AttentionEncoderConfig& cfg) : cfg_(cfg) {
  TORCH_CHECK(cfg.d_ego > 0 && cfg.d_ado > 0 && cfg.n_other > 0, "AttentionEncoder: d_ego, d_ado, n_other must be > 0");
  TORCH_CHECK(cfg.n_heads > 0 && cfg.d_model % cfg.n_heads == 0, "AttentionEncoder: d_model (", cfg.d_model,
              ") must be a multiple of n_heads (", cfg.n_heads, ")");
  q_proj_ = register_module("q_proj", torch::nn::Linear(cfg.d_ego, cfg.d_model));
  k_proj_ = register_module("k_proj", torch::nn::Linear(cfg.d_ado, cfg.d_model));
  v_proj_ = register_module("v_proj", torch::nn::Linear(cfg.d_ado, cfg.d_model));
  out_proj_ = register_module("out_proj", torch::nn::Linear(cfg.d_model, cfg.d_model));
}

int64_t AttentionEncoderImpl::flops_per_sample() const {
  const int64_t d = cfg_.d_model, n = cfg_.n_other;
  return 2 * cfg_.d_ego * d            // query
         + 2 * 2 * n * cfg_.d_ado * d  // keys and values of every other aircraft
         + 2 * n * d                   // scores (all heads together span d)
         + 2 * n * d                   // weighted sum of the values
         + 2 * d * d;                  // output projection
}

torch::Tensor AttentionEncoderImpl::forward(const torch::Tensor& ego, const torch::Tensor& ado,
                                            const torch::Tensor& ado_alive) {
  check_tensor(ego, "ego", {-1, cfg_.d_ego}, torch::kFloat32);
  const int64_t b = ego.size(0), n = cfg_.n_other, h = cfg_.n_heads, dh = cfg_.d_model / cfg_.n_heads;
  check_tensor(ado, "ado", {b, n, cfg_.d_ado}, torch::kFloat32);
  check_tensor(ado_alive, "ado_alive", {b, n}, torch::kBool);

  // One query per sample: scores and the weighted sum are elementwise products and sums over
  // [B, N, H, dh], measured ~2x faster here than 8192 x H tiny batched matrix products.
  const auto q = q_proj_(ego).view({b, 1, h, dh});
  const auto k = k_proj_(ado).view({b, n, h, dh});
  const auto v = v_proj_(ado).view({b, n, h, dh});
  auto scores = (k * q).sum(-1) / std::sqrt(static_cast<double>(dh));  // [B, N, H]
  const auto alive = ado_alive.view({b, n, 1});
  // A finite fill (not -inf) keeps all-dead rows free of NaN; exp(-1e9) is exactly 0 in float,
  // and the multiply by `alive` zeroes the uniform weights of an all-dead row.
  scores = scores.masked_fill(alive.logical_not(), -1e9);
  const auto weights = torch::softmax(scores, 1) * alive.to(torch::kFloat32);
  const auto attended = (weights.unsqueeze(-1) * v).sum(1).reshape({b, cfg_.d_model});  // [B, H * dh]
  const auto any_alive = ado_alive.any(1, /*keepdim=*/true).to(torch::kFloat32);
  return out_proj_(attended) * any_alive;  // drop the output bias too: exact zeros if nobody is alive
}

}  // namespace f16race::models
