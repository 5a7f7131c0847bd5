#include "models/ll_actor_critic.hpp"

#include <cmath>

#include "models/dense_linear.hpp"

namespace f16race::models {
namespace {

// CleanRL's layer_init: orthogonal weights with gain `std`, zero bias. The small gain on the
// policy output starts every action near zero mean, the unit gain on the value output keeps
// early value targets in range.
torch::nn::Linear init_linear(int64_t in, int64_t out, double gain) {
  torch::nn::Linear layer(in, out);
  torch::NoGradGuard no_grad;
  torch::nn::init::orthogonal_(layer->weight, gain);
  torch::nn::init::zeros_(layer->bias);
  return layer;
}

torch::nn::Sequential make_mlp(int64_t in, const std::vector<int64_t>& hidden, int64_t out, double out_gain) {
  torch::nn::Sequential mlp;
  for (int64_t width : hidden) {
    mlp->push_back(init_linear(in, width, std::sqrt(2.0)));
    mlp->push_back(torch::nn::Tanh());
    in = width;
  }
  mlp->push_back(init_linear(in, out, out_gain));
  return mlp;
}

}  // namespace

LlActorCriticImpl::LlActorCriticImpl(const LlActorCriticConfig& cfg) : cfg_(cfg) {
  TORCH_CHECK(cfg.action_dim > 0 && !cfg.hidden.empty(), "LlActorCritic: action_dim > 0 and a hidden layer needed");
  encoder_ = register_module("encoder", AttentionEncoder(AttentionEncoderConfig{cfg.dims.d_ego, cfg.dims.d_ado,
                                                                                 cfg.dims.n_other, cfg.d_model,
                                                                                 cfg.n_heads}));
  const int64_t in = cfg.dims.d_ego + cfg.dims.d_goal + cfg.d_model + cfg.dims.d_task;
  actor_ = register_module("actor", make_mlp(in, cfg.hidden, cfg.action_dim, 0.01));
  critic_ = register_module("critic", make_mlp(in, cfg.hidden, 1, 1.0));
  log_std_ = register_parameter("log_std", torch::full({cfg.action_dim}, cfg.init_log_std));
}

int64_t LlActorCriticImpl::flops_per_sample() const {
  // Actor and critic share the input and the hidden widths; only their outputs differ.
  auto mlp = [&](int64_t out) {
    int64_t flops = 0, in = cfg_.dims.d_ego + cfg_.dims.d_goal + cfg_.d_model + cfg_.dims.d_task;
    for (int64_t width : cfg_.hidden) {
      flops += 2 * in * width;
      in = width;
    }
    return flops + 2 * in * out;
  };
  return encoder_->flops_per_sample() + mlp(cfg_.action_dim) + mlp(1);
}

LlOutput LlActorCriticImpl::forward(const LlObs& obs) {
  const int64_t b = check_obs(obs, cfg_.dims);
  const auto encoded = encoder_(obs.ego, obs.ado, obs.ado_alive);
  const auto x = torch::cat({obs.ego, obs.goal, encoded, obs.task}, 1);
  LlOutput out;
  out.mean = forward_mlp(actor_, x);
  out.log_std = log_std_.expand({b, cfg_.action_dim});
  out.value = forward_mlp(critic_, x).squeeze(1);
  return out;
}

AttentionMlpWeights LlActorCriticImpl::eigen_weights() const {
  AttentionMlpWeights w = encoder_weights(encoder_, cfg_.dims);
  w.mlp = dense_layers(actor_);
  w.value_mlp = dense_layers(critic_);
  w.activation = Activation::kTanh;
  return w;
}

kernels::AttentionMlpTrainNet LlActorCriticImpl::train_net() const {
  kernels::AttentionMlpTrainNet n = encoder_train_net(encoder_, cfg_.dims, cfg_.dims.d_goal);
  for (const auto& l : linear_modules(actor_)) n.actor.push_back(dense_view(l));
  for (const auto& l : linear_modules(critic_)) n.critic.push_back(dense_view(l));
  return n;
}

kernels::AttentionMlpTrainGrads LlActorCriticImpl::train_grads(const std::vector<torch::Tensor>& grads) const {
  kernels::AttentionMlpTrainGrads g = encoder_train_grads(*this, grads, encoder_);
  for (const auto& l : linear_modules(actor_)) g.actor.push_back(dense_grad_view(*this, grads, l));
  for (const auto& l : linear_modules(critic_)) g.critic.push_back(dense_grad_view(*this, grads, l));
  return g;
}

torch::Tensor gaussian_log_prob(const torch::Tensor& mean, const torch::Tensor& log_std, const torch::Tensor& action) {
  const auto z = (action - mean) * torch::exp(-log_std);
  return (-0.5 * z * z - log_std - 0.5 * std::log(2.0 * M_PI)).sum(-1);
}

torch::Tensor gaussian_entropy(const torch::Tensor& log_std) {
  return (log_std + 0.5 * (1.0 + std::log(2.0 * M_PI))).sum(-1);
}

}  // namespace f16race::models
