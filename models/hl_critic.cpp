#include "models/hl_critic.hpp"

#include <string>

namespace f16race::models {

HlCriticImpl::HlCriticImpl(const HlCriticConfig& cfg) : cfg_(cfg) {
  TORCH_CHECK(cfg.n_bins > 1 && cfg.n_atoms >= 1, "HlCritic: n_bins must be > 1 and n_atoms >= 1");
  TORCH_CHECK(cfg.n_atoms == 1 || cfg.v_max > cfg.v_min, "HlCritic: v_max must exceed v_min");
  TORCH_CHECK(!cfg.hidden.empty(), "HlCritic: hidden must list at least one layer");
  TORCH_CHECK(!cfg.per_axis || cfg.decoupled, "HlCritic: per_axis needs the decoupled head");
  const int64_t n_branches = cfg.per_axis ? 3 : 1;
  const int64_t n_out = (cfg.decoupled ? 3 * cfg.n_bins : n_joint_actions()) * cfg.n_atoms / n_branches;
  for (int64_t k = 0; k < n_branches; ++k) {
    const std::string suffix = cfg.per_axis ? std::string("_") + "xyz"[k] : "";
    encoders_.push_back(register_module(
        "encoder" + suffix, AttentionEncoder(AttentionEncoderConfig{cfg.dims.d_ego, cfg.dims.d_ado, cfg.dims.n_other,
                                                                   cfg.d_model, cfg.n_heads})));
    auto trunk = torch::nn::Sequential();
    int64_t in = cfg.dims.d_ego + cfg.dims.d_prev_action + cfg.d_model + cfg.dims.d_task;
    for (int64_t width : cfg.hidden) {
      trunk->push_back(torch::nn::Linear(in, width));
      trunk->push_back(torch::nn::ReLU());
      in = width;
    }
    trunks_.push_back(register_module("trunk" + suffix, trunk));
    heads_.push_back(register_module("head" + suffix, torch::nn::Linear(in, n_out)));
  }
  atoms_ = register_buffer("atoms", cfg.n_atoms > 1 ? torch::linspace(cfg.v_min, cfg.v_max, cfg.n_atoms)
                                                    : torch::zeros({1}));
}

int64_t HlCriticImpl::flops_per_sample() const {
  int64_t flops = 0;
  for (std::size_t k = 0; k < encoders_.size(); ++k) {
    flops += encoders_[k]->flops_per_sample();
    int64_t in = cfg_.dims.d_ego + cfg_.dims.d_prev_action + cfg_.d_model + cfg_.dims.d_task;
    for (int64_t width : cfg_.hidden) {
      flops += 2 * in * width;
      in = width;
    }
    flops += 2 * in * heads_[k]->options.out_features();
  }
  return flops;
}

HlOutput HlCriticImpl::forward(const HlObs& obs, bool with_q) {
  check_obs(obs, cfg_.dims);
  std::vector<torch::Tensor> outs;
  for (std::size_t k = 0; k < encoders_.size(); ++k) {
    const auto encoded = encoders_[k](obs.ego, obs.ado, obs.ado_alive);
    outs.push_back(heads_[k](trunks_[k]->forward(torch::cat({obs.ego, obs.prev_action, encoded, obs.task}, 1))));
  }
  // [B, 3 * n_bins * K]: axis-major, as the single head writes it
  return from_head(outs.size() == 1 ? outs[0] : torch::cat(outs, 1), with_q);
}

HlOutput HlCriticImpl::from_head(const torch::Tensor& out, bool with_q) const {
  const int64_t b = out.size(0);
  const std::vector<int64_t> action_shape =
      cfg_.decoupled ? std::vector<int64_t>{b, 3, cfg_.n_bins} : std::vector<int64_t>{b, n_joint_actions()};
  HlOutput result;
  if (cfg_.n_atoms == 1) {
    result.q = out.view(action_shape);
    return result;
  }
  auto shape = action_shape;
  shape.push_back(cfg_.n_atoms);
  result.log_probs = torch::log_softmax(out.view(shape), -1);
  if (with_q) result.q = (result.log_probs.exp() * atoms_).sum(-1);
  return result;
}

AttentionMlpWeights HlCriticImpl::eigen_weights() const {
  TORCH_CHECK(has_eigen_weights(), "HlCritic::eigen_weights: one critic per goal axis has no single-branch copy");
  AttentionMlpWeights w = encoder_weights(encoders_[0], cfg_.dims);
  w.mlp = dense_layers(trunks_[0]);
  w.mlp.push_back(dense_layer(heads_[0]));
  w.activation = Activation::kRelu;
  return w;
}

int64_t HlCriticImpl::head_width() const {
  return (cfg_.decoupled ? 3 * cfg_.n_bins : n_joint_actions()) * cfg_.n_atoms;
}

}  // namespace f16race::models
