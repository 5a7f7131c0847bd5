#include "agents/ppo_fused_loss.hpp"

#include <algorithm>
#include <array>
#include <cmath>

namespace f16race::agents {
namespace {

// d max(a, b): LibTorch's maximum sends the gradient to the larger input and half to each on a tie.
inline double max_grad(double a, double b, double da, double db) {
  return a > b ? da : (a < b ? db : 0.5 * (da + db));
}

}  // namespace

std::array<double, 5> ppo_loss_rows(const PpoLossRows& in, const PpoLossGrads& out) {
  const int64_t m = in.m, a_dim = in.a_dim;
  const double half_log_2pi = 0.5 * std::log(2.0 * M_PI), inv_m = 1.0 / static_cast<double>(m);
  const double clip = in.clip, weight = in.weight, ent_coef = in.ent_coef;
  double policy = 0.0, value_sum = 0.0, entropy = 0.0, kl = 0.0, clipped = 0.0;
  if (out.d_log_std_sum != nullptr) std::fill_n(out.d_log_std_sum, a_dim, 0.0);
  for (int64_t i = 0; i < m; ++i) {
    const float *mu = in.mean + i * a_dim, *ls = in.log_std + i * in.log_std_row_stride, *ac = in.action + i * a_dim;
    double log_prob = 0.0;
    for (int64_t j = 0; j < a_dim; ++j) {
      const double s = ls[j], z = (ac[j] - mu[j]) * std::exp(-s);
      log_prob += -0.5 * z * z - s - half_log_2pi;
      entropy += s + 0.5 + half_log_2pi;
    }
    const double log_ratio = log_prob - in.old_log_prob[i], ratio = std::exp(log_ratio);
    kl += (ratio - 1.0) - log_ratio;
    clipped += std::abs(ratio - 1.0) > clip ? 1.0 : 0.0;
    const double adv_i = in.advantages[i], ratio_c = std::clamp(ratio, 1.0 - clip, 1.0 + clip);
    const double pg1 = -adv_i * ratio, pg2 = -adv_i * ratio_c;
    policy += std::max(pg1, pg2);
    const double inside = ratio >= 1.0 - clip && ratio <= 1.0 + clip ? 1.0 : 0.0;
    // d policy_loss / d log_prob_i = d max / d ratio * ratio / M.
    const double d_log_prob = max_grad(pg1, pg2, -adv_i, -adv_i * inside) * ratio * inv_m * weight;
    for (int64_t j = 0; j < a_dim; ++j) {
      const double s = ls[j], inv_std = std::exp(-s);
      const double z = (ac[j] - mu[j]) * inv_std;
      const double dls = d_log_prob * (z * z - 1.0) - ent_coef * inv_m * weight;
      out.d_mean[i * a_dim + j] = static_cast<float>(d_log_prob * z * inv_std);
      if (out.d_log_std != nullptr) out.d_log_std[i * a_dim + j] = static_cast<float>(dls);
      if (out.d_log_std_sum != nullptr) out.d_log_std_sum[j] += dls;
    }
    const float v = in.value[i], ov = in.old_value[i], rt = in.returns[i];
    const double e = v - rt, unclipped = e * e;  // float differences, as LibTorch's ops (the oracle)
    double vl = unclipped, d_vl = 2.0 * e;
    if (in.clip_value) {
      const double diff = v - ov, vc = ov + std::clamp(diff, -clip, clip), ec = vc - rt;
      const double in_range = diff >= -clip && diff <= clip ? 1.0 : 0.0;
      vl = std::max(unclipped, ec * ec);
      d_vl = max_grad(unclipped, ec * ec, 2.0 * e, 2.0 * ec * in_range);
    }
    value_sum += vl;
    out.d_value[i] = static_cast<float>(in.vf_coef * 0.5 * d_vl * inv_m * weight);
  }
  return {policy * inv_m, 0.5 * value_sum * inv_m, entropy * inv_m, kl * inv_m, clipped * inv_m};
}

namespace {

struct Constants {
  torch::Tensor action, old_log_prob, advantages, old_value, returns;
};

class PpoLossNode : public torch::autograd::Function<PpoLossNode> {
 public:
  // Returns {total [], terms [5] (policy, value, entropy, approx_kl, clip_fraction; no gradient)}.
  static torch::autograd::variable_list forward(torch::autograd::AutogradContext* ctx, const torch::Tensor& mean_in,
                                                const torch::Tensor& log_std_in, const torch::Tensor& value_in,
                                                const Constants& k, double clip, bool clip_value, double vf_coef,
                                                double ent_coef, double weight) {
    const auto mean = mean_in.contiguous(), log_std = log_std_in.contiguous(), value = value_in.contiguous();
    const auto action = k.action.contiguous(), old_lp = k.old_log_prob.contiguous(),
               adv = k.advantages.contiguous(), old_v = k.old_value.contiguous(), ret = k.returns.contiguous();
    const int64_t m = mean.size(0), a_dim = mean.size(1);
    // d(total)/d(output) per element, before the incoming gradient: the backward only scales them.
    auto d_mean = torch::empty({m, a_dim}), d_log_std = torch::empty({m, a_dim}), d_value = torch::empty({m});
    PpoLossRows in;
    in.m = m, in.a_dim = a_dim;
    in.mean = mean.data_ptr<float>(), in.log_std = log_std.data_ptr<float>(), in.log_std_row_stride = a_dim;
    in.value = value.data_ptr<float>(), in.action = action.data_ptr<float>();
    in.old_log_prob = old_lp.data_ptr<float>(), in.advantages = adv.data_ptr<float>();
    in.old_value = old_v.data_ptr<float>(), in.returns = ret.data_ptr<float>();
    in.clip = clip, in.clip_value = clip_value, in.vf_coef = vf_coef, in.ent_coef = ent_coef, in.weight = weight;
    PpoLossGrads out;
    out.d_mean = d_mean.data_ptr<float>(), out.d_log_std = d_log_std.data_ptr<float>();
    out.d_value = d_value.data_ptr<float>();
    const std::array<double, 5> t = ppo_loss_rows(in, out);
    const double policy_loss = t[0], value_loss = t[1], ent = t[2];
    auto terms = torch::tensor({t[0], t[1], t[2], t[3], t[4]}, torch::kFloat64);
    ctx->mark_non_differentiable({terms});
    ctx->save_for_backward({d_mean, d_log_std, d_value});
    const double total = weight * (policy_loss - ent_coef * ent + vf_coef * value_loss);
    return {torch::tensor(static_cast<float>(total)), terms};
  }

  static torch::autograd::variable_list backward(torch::autograd::AutogradContext* ctx,
                                                 torch::autograd::variable_list grads) {
    const auto saved = ctx->get_saved_variables();
    const auto g = grads[0];
    // One gradient per forward input: the three outputs, then none for the constants and scalars.
    return {saved[0] * g, saved[1] * g, saved[2] * g, torch::Tensor(), torch::Tensor(), torch::Tensor(),
            torch::Tensor(), torch::Tensor(), torch::Tensor()};
  }
};

}  // namespace

FusedPpoLoss fused_ppo_loss(const torch::Tensor& mean, const torch::Tensor& log_std, const torch::Tensor& value,
                            const torch::Tensor& action, const torch::Tensor& old_log_prob,
                            const torch::Tensor& advantages, const torch::Tensor& old_value,
                            const torch::Tensor& returns, const PpoConfig& cfg, double weight) {
  TORCH_CHECK(!cfg.normalize_advantages, "fused_ppo_loss: normalise the advantages before (PpoAgent::update does)");
  TORCH_CHECK(mean.dim() == 2 && mean.size(0) >= 1 && log_std.sizes() == mean.sizes() && action.sizes() == mean.sizes(),
              "fused_ppo_loss: mean, log_std and action must be [M, A] with M >= 1");
  const int64_t m = mean.size(0);
  for (const torch::Tensor* t : {&value, &old_log_prob, &advantages, &old_value, &returns})
    TORCH_CHECK(t->dim() == 1 && t->size(0) == m && t->scalar_type() == torch::kFloat32,
                "fused_ppo_loss: value, old_log_prob, advantages, old_value, returns must be float [M]");
  const Constants k{action, old_log_prob, advantages, old_value, returns};
  const auto out = PpoLossNode::apply(mean, log_std, value, k, cfg.clip_coef, cfg.clip_value_loss, cfg.vf_coef,
                                      cfg.ent_coef, weight);
  FusedPpoLoss r;
  r.total = out[0];
  const double* t = out[1].data_ptr<double>();
  r.policy_loss = t[0];
  r.value_loss = t[1];
  r.entropy = t[2];
  r.approx_kl = t[3];
  r.clip_fraction = t[4];
  return r;
}

}  // namespace f16race::agents
