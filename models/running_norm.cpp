#include "models/running_norm.hpp"

namespace f16race::models {

RunningNormImpl::RunningNormImpl(int64_t dim, double clip, double eps) : dim_(dim), clip_(clip), eps_(eps) {
  TORCH_CHECK(dim > 0, "RunningNorm: dim must be > 0");
  // gym's initial state: mean 0, var 1, count 1e-4 (a tiny prior that avoids dividing by 0).
  mean_ = register_buffer("mean", torch::zeros({dim}, torch::kFloat64));
  var_ = register_buffer("var", torch::ones({dim}, torch::kFloat64));
  count_ = register_buffer("count", torch::full({}, 1e-4, torch::kFloat64));
}

void RunningNormImpl::update(const torch::Tensor& x) {
  check_tensor(x, "x", {-1, dim_}, torch::kFloat32);
  if (x.size(0) == 0) return;
  torch::NoGradGuard no_grad;
  const auto xd = x.to(torch::kFloat64);
  const auto batch_mean = xd.mean(0);
  const auto batch_var = xd.var(0, /*unbiased=*/false);
  const double batch_count = static_cast<double>(x.size(0));
  const double count = count_.item<double>();
  const double total = count + batch_count;
  const auto delta = batch_mean - mean_;
  const auto m2 = var_ * count + batch_var * batch_count + delta * delta * (count * batch_count / total);
  mean_.add_(delta * (batch_count / total));
  var_.copy_(m2 / total);
  count_.fill_(total);
}

torch::Tensor RunningNormImpl::normalize(const torch::Tensor& x) const {
  TORCH_CHECK(x.dim() >= 1 && x.size(-1) == dim_, "RunningNorm: last dimension of x is ", x.size(-1), ", expected ",
              dim_);
  return torch::clamp((x - mean_f32()) * inv_std_f32(), -clip_, clip_);
}

ObsNormalizerImpl::ObsNormalizerImpl(const ObsDims& dims, double clip) : dims_(dims) {
  ego_ = register_module("ego", RunningNorm(dims.d_ego, clip));
  // One normaliser for the 3-wide input of either level: prev_action (HL) or goal (LL).
  TORCH_CHECK(dims.d_prev_action == dims.d_goal, "ObsNormalizer: prev_action and goal widths must match");
  extra_ = register_module("extra", RunningNorm(dims.d_goal, clip));
  ado_norm_ = register_module("ado", RunningNorm(dims.d_ado, clip));
  task_ = register_module("task", RunningNorm(dims.d_task, clip));
}

torch::Tensor ObsNormalizerImpl::ado_(const torch::Tensor& ado, const torch::Tensor& alive, bool update_stats) {
  if (update_stats) ado_norm_->update(ado.reshape({-1, dims_.d_ado}).index({alive.reshape({-1})}));
  return ado_norm_->normalize(ado) * alive.unsqueeze(-1).to(torch::kFloat32);
}

HlObs ObsNormalizerImpl::normalize(const HlObs& obs, bool update_stats) {
  check_obs(obs, dims_);
  torch::NoGradGuard no_grad;
  if (update_stats) {
    ego_->update(obs.ego);
    extra_->update(obs.prev_action);
    task_->update(obs.task);
  }
  return {ego_->normalize(obs.ego), extra_->normalize(obs.prev_action), ado_(obs.ado, obs.ado_alive, update_stats),
          obs.ado_alive, task_->normalize(obs.task)};
}

LlObs ObsNormalizerImpl::normalize(const LlObs& obs, bool update_stats) {
  check_obs(obs, dims_);
  torch::NoGradGuard no_grad;
  if (update_stats) {
    ego_->update(obs.ego);
    extra_->update(obs.goal);
    task_->update(obs.task);
  }
  return {ego_->normalize(obs.ego), extra_->normalize(obs.goal), ado_(obs.ado, obs.ado_alive, update_stats),
          obs.ado_alive, task_->normalize(obs.task)};
}

}  // namespace f16race::models
