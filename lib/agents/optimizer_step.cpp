#include "agents/optimizer_step.hpp"

#include <cmath>

#include "agents/kernels/adam_kernel.hpp"

namespace f16race::agents {

void sum_chunk_gradients(const std::vector<torch::Tensor>& params,
                         const std::vector<const std::vector<torch::Tensor>*>& chunk_grads, bool zero_unused) {
  for (std::size_t p = 0; p < params.size(); ++p) {
    torch::Tensor param = params[p];
    const int64_t n = param.numel();
    torch::Tensor& grad = param.mutable_grad();
    bool any = false;
    float* dst = nullptr;
    for (const auto* chunk : chunk_grads) {
      if (chunk->empty() || !(*chunk)[p].defined()) continue;
      const torch::Tensor g = (*chunk)[p].contiguous();
      const float* src = g.data_ptr<float>();
      if (!any) {
        // The parameter's own buffer, reused across steps (an optimiser or a reduction may have
        // replaced it by a tensor of the right shape; anything else is replaced here).
        if (!grad.defined() || !grad.is_contiguous() || grad.sizes() != param.sizes() ||
            grad.scalar_type() != torch::kFloat32)
          grad = torch::empty_like(param, torch::MemoryFormat::Contiguous);
        dst = grad.data_ptr<float>();
        std::copy(src, src + n, dst);
        any = true;
      } else {
        for (int64_t i = 0; i < n; ++i) dst[i] += src[i];
      }
    }
    if (!any) grad = zero_unused ? torch::zeros_like(param) : torch::Tensor();
  }
}

double clip_and_adam_step(torch::optim::Adam& opt, double max_grad_norm) {
  auto& groups = opt.param_groups();
  std::vector<torch::Tensor> with_grad;
  for (auto& group : groups)
    for (auto& p : group.params())
      if (p.grad().defined()) with_grad.push_back(p);
  bool plain = true;
  for (auto& group : groups) {
    const auto& o = static_cast<const torch::optim::AdamOptions&>(group.options());
    plain = plain && o.weight_decay() == 0.0 && !o.amsgrad();
  }
  if (!plain) {
    const double norm = torch::nn::utils::clip_grad_norm_(with_grad, max_grad_norm);
    opt.step();
    return norm;
  }
  double sum_sq = 0.0;
  for (auto& p : with_grad) {
    const torch::Tensor g = p.grad().contiguous();
    sum_sq += kernels::sum_of_squares(g.data_ptr<float>(), g.numel());
  }
  const double norm = std::sqrt(sum_sq);
  const double clip = max_grad_norm / (norm + 1e-6);
  const float grad_scale = clip < 1.0 ? static_cast<float>(clip) : 1.0f;
  for (auto& group : groups) {
    const auto& o = static_cast<const torch::optim::AdamOptions&>(group.options());
    const double beta1 = std::get<0>(o.betas()), beta2 = std::get<1>(o.betas());
    for (auto& p : group.params()) {
      if (!p.grad().defined()) continue;
      const std::string key = c10::guts::to_string(p.unsafeGetTensorImpl());
      auto it = opt.state().find(key);
      if (it == opt.state().end()) {
        auto fresh = std::make_unique<torch::optim::AdamParamState>();
        fresh->step(0);
        fresh->exp_avg(torch::zeros_like(p, torch::MemoryFormat::Contiguous));
        fresh->exp_avg_sq(torch::zeros_like(p, torch::MemoryFormat::Contiguous));
        it = opt.state().emplace(key, std::move(fresh)).first;
      }
      auto& st = static_cast<torch::optim::AdamParamState&>(*it->second);
      // A state read from a checkpoint may not be contiguous: make it so once.
      if (!st.exp_avg().is_contiguous()) st.exp_avg(st.exp_avg().contiguous());
      if (!st.exp_avg_sq().is_contiguous()) st.exp_avg_sq(st.exp_avg_sq().contiguous());
      st.step(st.step() + 1);
      const double t = static_cast<double>(st.step());
      kernels::AdamScalars s;
      s.grad_scale = grad_scale;
      s.beta1 = static_cast<float>(beta1);
      s.beta2 = static_cast<float>(beta2);
      s.one_minus_beta1 = static_cast<float>(1.0 - beta1);
      s.one_minus_beta2 = static_cast<float>(1.0 - beta2);
      s.inv_sqrt_bias_correction2 = static_cast<float>(1.0 / std::sqrt(1.0 - std::pow(beta2, t)));
      s.eps = static_cast<float>(o.eps());
      s.step_size = static_cast<float>(o.lr() / (1.0 - std::pow(beta1, t)));
      const torch::Tensor g = p.grad().contiguous();
      // The parameter's memory directly (an optimiser's update is outside autograd).
      torch::Tensor data = p.detach();
      TORCH_CHECK(data.is_contiguous(), "clip_and_adam_step: a parameter is not contiguous");
      kernels::adam_update(s, g.data_ptr<float>(), st.exp_avg().data_ptr<float>(), st.exp_avg_sq().data_ptr<float>(),
                           data.data_ptr<float>(), p.numel());
      // An in-place write like LibTorch's own: the version counter moves, so whatever keys on it
      // (autograd's saved tensors, EsAgent's Eigen copy of the critic) sees the new weights.
      p.unsafeGetTensorImpl()->bump_version();
    }
  }
  return norm;
}

}  // namespace f16race::agents
