#include "models/hl_critic.hpp"

#include <string>

#include "models/dense_linear.hpp"

namespace f16race::models {

HlCriticImpl::HlCriticImpl(const HlCriticConfig& cfg) : cfg_(cfg) {
  TORCH_CHECK(cfg.n_bins > 1 && cfg.n_atoms >= 1, "HlCritic: n_bins must be > 1 and n_atoms >= 1");
  TORCH_CHECK(cfg.n_atoms == 1 || cfg.v_max > cfg.v_min, "HlCritic: v_max must exceed v_min");
  TORCH_CHECK(!cfg.hidden.empty(), "HlCritic: hidden must list at least one layer");
  encoder_ = register_module("encoder", AttentionEncoder(AttentionEncoderConfig{cfg.dims.d_ego, cfg.dims.d_ado,
                                                                               cfg.dims.n_other, cfg.d_model, cfg.n_heads}));
  trunk_ = torch::nn::Sequential();
  int64_t in = cfg.dims.d_ego + cfg.dims.d_prev_action + cfg.d_model + cfg.dims.d_task;
  for (int64_t width : cfg.hidden) {
    trunk_->push_back(torch::nn::Linear(in, width));
    trunk_->push_back(torch::nn::ReLU());
    in = width;
  }
  register_module("trunk", trunk_);
  head_ = register_module("head", torch::nn::Linear(in, head_width()));
  atoms_ = register_buffer("atoms", cfg.n_atoms > 1 ? torch::linspace(cfg.v_min, cfg.v_max, cfg.n_atoms)
                                                    : torch::zeros({1}));
}

int64_t HlCriticImpl::flops_per_sample() const {
  int64_t flops = encoder_->flops_per_sample();
  int64_t in = cfg_.dims.d_ego + cfg_.dims.d_prev_action + cfg_.d_model + cfg_.dims.d_task;
  for (int64_t width : cfg_.hidden) {
    flops += 2 * in * width;
    in = width;
  }
  return flops + 2 * in * head_width();
}

HlOutput HlCriticImpl::forward(const HlObs& obs, bool with_q) {
  check_obs(obs, cfg_.dims);
  const auto encoded = encoder_(obs.ego, obs.ado, obs.ado_alive);
  // [B, head_width()]: axis-major, atoms innermost
  const auto hidden = forward_mlp(trunk_, torch::cat({obs.ego, obs.prev_action, encoded, obs.task}, 1));
  return from_head(dense_linear(hidden, head_), with_q);
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
  AttentionMlpWeights w = encoder_weights(encoder_, cfg_.dims);
  w.mlp = dense_layers(trunk_);
  w.mlp.push_back(dense_layer(head_));
  w.activation = Activation::kRelu;
  return w;
}

kernels::AttentionMlpTrainNet HlCriticImpl::train_net() const {
  kernels::AttentionMlpTrainNet n = encoder_train_net(encoder_, cfg_.dims, cfg_.dims.d_prev_action);
  for (const auto& l : linear_modules(trunk_)) n.actor.push_back(dense_view(l));
  n.actor.push_back(dense_view(head_));
  n.relu = true;
  return n;
}

kernels::AttentionMlpTrainGrads HlCriticImpl::train_grads(const std::vector<torch::Tensor>& grads) const {
  kernels::AttentionMlpTrainGrads g = encoder_train_grads(*this, grads, encoder_);
  for (const auto& l : linear_modules(trunk_)) g.actor.push_back(dense_grad_view(*this, grads, l));
  g.actor.push_back(dense_grad_view(*this, grads, head_));
  return g;
}

int64_t HlCriticImpl::head_width() const {
  return (cfg_.decoupled ? 3 * cfg_.n_bins : n_joint_actions()) * cfg_.n_atoms;
}

}  // namespace f16race::models
