#include "agents/es_fused_loss.hpp"

#include <algorithm>
#include <cmath>
#include <limits>
#include <vector>

namespace f16race::agents {
namespace {

struct Inputs {
  torch::Tensor actions, active, target_dist, target_value;
  C51Support support;
};

// Teams with any active member (es_loss's `valid`), of active [t, n_a].
int64_t valid_teams(const bool* act, int64_t t, int64_t n_a) {
  int64_t n = 0;
  for (int64_t team = 0; team < t; ++team)
    n += std::any_of(act + team * n_a, act + (team + 1) * n_a, [](bool x) { return x; }) ? 1 : 0;
  return n;
}

// A team-loss node's outputs: weight * loss (the differentiable scalar) and the unweighted loss, q
// and td as a float64 [3] without gradient; `grad` (d weight * loss / d input) is saved for backward.
torch::autograd::variable_list team_loss_outputs(torch::autograd::AutogradContext* ctx, const torch::Tensor& grad,
                                                 double loss, double q, double td, double inv_valid, double weight) {
  auto stats = torch::tensor({loss * inv_valid, q * inv_valid, td * inv_valid}, torch::kFloat64);
  ctx->mark_non_differentiable({stats});
  ctx->save_for_backward({grad});
  return {torch::tensor(static_cast<float>(weight * loss * inv_valid)), stats};
}

// Huber's loss and its derivative in the residual d, as torch::huber_loss computes them (the
// quadratic branch up to and including |d| = delta).
double huber(double d, double delta) {
  const double z = std::abs(d);
  return z <= delta ? 0.5 * d * d : delta * (z - 0.5 * delta);
}
double huber_slope(double d, double delta) { return d < -delta ? -delta : (d > delta ? delta : d); }

}  // namespace

EsLossSums es_d2_loss_rows(const EsTeamRows& rows, const float* qv, double huber_delta, float* g) {
  const int64_t t = rows.t, n_a = rows.n_a, n_bins = rows.n_bins;
  const int64_t* a = rows.actions;
  const bool* act = rows.active;
  const float* v = rows.target_value;
  const double weight = rows.weight;
  // Where member i of a team took bin a on axis j: (row, axis, bin) of q.
  auto at = [&](int64_t team, int64_t i, int64_t j) {
    const int64_t r = team * n_a + i;
    return (r * 3 + j) * n_bins + a[r * 3 + j];
  };
  const double inv_valid = 1.0 / static_cast<double>(std::max<int64_t>(valid_teams(act, t, n_a), 1));
  std::fill_n(g, t * n_a * 3 * n_bins, 0.0f);
  double loss = 0.0, q_sum = 0.0, td = 0.0;
  for (int64_t team = 0; team < t; ++team) {
    int64_t members = 0;
    double sum = 0.0;
    for (int64_t i = 0; i < n_a; ++i) {
      if (!act[team * n_a + i]) continue;
      ++members;
      sum += (static_cast<double>(qv[at(team, i, 0)]) + qv[at(team, i, 1)] + qv[at(team, i, 2)]) / 3.0;
    }
    if (members == 0) continue;  // not a valid team: no loss, no gradient
    const double pred = sum / static_cast<double>(members), d = pred - static_cast<double>(v[team]);
    loss += huber(d, huber_delta);
    q_sum += pred;
    td += std::abs(d);
    // d loss / d Q^{i,j}(a^{i,j}) = huber'(d) / n_valid / members / 3 for each active member.
    const float gi =
        static_cast<float>(huber_slope(d, huber_delta) * inv_valid / (3.0 * static_cast<double>(members)) * weight);
    for (int64_t i = 0; i < n_a; ++i) {
      if (!act[team * n_a + i]) continue;
      for (int64_t j = 0; j < 3; ++j) g[at(team, i, j)] = gi;
    }
  }
  return {loss, q_sum, td, inv_valid};
}

EsLossSums es_d3_loss_rows(const EsTeamRows& rows, const float* l, const C51Support& support, float* g) {
  const int64_t t = rows.t, n_a = rows.n_a, n_bins = rows.n_bins, k = support.n_atoms;
  const int64_t* a = rows.actions;
  const bool* act = rows.active;
  const float *d = rows.target_dist, *v = rows.target_value;
  const double weight = rows.weight;
  // Where the taken bin's K atoms start in log_probs, per (team, member, axis).
  auto offset = [&](int64_t team, int64_t i, int64_t j) {
    return (((team * n_a + i) * 3 + j) * n_bins + a[(team * n_a + i) * 3 + j]) * k;
  };
  const double inv_valid = 1.0 / static_cast<double>(std::max<int64_t>(valid_teams(act, t, n_a), 1));
  const double delta = support.delta();
  std::fill_n(g, t * n_a * 3 * n_bins * k, 0.0f);
  std::vector<double> mx(static_cast<std::size_t>(k)), sum(static_cast<std::size_t>(k));
  double loss = 0.0, q = 0.0, td = 0.0;
  for (int64_t team = 0; team < t; ++team) {
    int64_t members = 0;
    for (int64_t i = 0; i < n_a; ++i) members += act[team * n_a + i] ? 1 : 0;
    if (members == 0) continue;  // not a valid team: no loss, no gradient
    const double log_terms = std::log(3.0 * static_cast<double>(members));
    std::fill(mx.begin(), mx.end(), -std::numeric_limits<double>::infinity());
    std::fill(sum.begin(), sum.end(), 0.0);
    for (int64_t i = 0; i < n_a; ++i) {
      if (!act[team * n_a + i]) continue;
      for (int64_t j = 0; j < 3; ++j) {
        const float* x = l + offset(team, i, j);
        for (int64_t c = 0; c < k; ++c) mx[c] = std::max(mx[c], static_cast<double>(x[c]));
      }
    }
    for (int64_t i = 0; i < n_a; ++i) {
      if (!act[team * n_a + i]) continue;
      for (int64_t j = 0; j < 3; ++j) {
        const float* x = l + offset(team, i, j);
        for (int64_t c = 0; c < k; ++c) sum[c] += std::exp(x[c] - mx[c]);
      }
    }
    double ce = 0.0, pred = 0.0;
    for (int64_t c = 0; c < k; ++c) {
      const double log_team = mx[c] + std::log(sum[c]) - log_terms;
      ce -= d[team * k + c] * log_team;
      pred += std::exp(log_team) * (support.v_min + delta * static_cast<double>(c));
    }
    loss += ce;
    q += pred;
    td += std::abs(pred - v[team]);
    // d loss / d x_ijc = -target_c * softmax over the team's (i, j) of x_..c, / n_valid.
    for (int64_t i = 0; i < n_a; ++i) {
      if (!act[team * n_a + i]) continue;
      for (int64_t j = 0; j < 3; ++j) {
        const int64_t o = offset(team, i, j);
        for (int64_t c = 0; c < k; ++c)
          g[o + c] = static_cast<float>(-d[team * k + c] * std::exp(l[o + c] - mx[c]) / sum[c] * inv_valid * weight);
      }
    }
  }
  return {loss, q, td, inv_valid};
}

namespace {

class EsD2LossNode : public torch::autograd::Function<EsD2LossNode> {
 public:
  // Returns {weight * loss [], stats [3] (loss, q, td; no gradient)}.
  static torch::autograd::variable_list forward(torch::autograd::AutogradContext* ctx, const torch::Tensor& q_in,
                                                const Inputs& in, double huber_delta, double weight) {
    const auto q = q_in.contiguous();
    const auto actions = in.actions.contiguous(), active = in.active.contiguous(), value = in.target_value.contiguous();
    EsTeamRows rows;
    rows.t = actions.size(0), rows.n_a = actions.size(1), rows.n_bins = q.size(2);
    rows.actions = actions.data_ptr<int64_t>(), rows.active = active.data_ptr<bool>();
    rows.target_value = value.data_ptr<float>(), rows.weight = weight;
    auto grad = torch::empty_like(q);
    const EsLossSums r = es_d2_loss_rows(rows, q.data_ptr<float>(), huber_delta, grad.data_ptr<float>());
    const double loss = r.loss, q_sum = r.q, td = r.td, inv_valid = r.inv_valid;
    return team_loss_outputs(ctx, grad, loss, q_sum, td, inv_valid, weight);
  }

  static torch::autograd::variable_list backward(torch::autograd::AutogradContext* ctx,
                                                 torch::autograd::variable_list grads) {
    // One gradient per forward input: q, then none for the inputs, delta and the weight.
    return {ctx->get_saved_variables()[0] * grads[0], torch::Tensor(), torch::Tensor(), torch::Tensor()};
  }
};

class EsD3LossNode : public torch::autograd::Function<EsD3LossNode> {
 public:
  // Returns {weight * loss [], stats [3] (loss, q, td; no gradient)}.
  static torch::autograd::variable_list forward(torch::autograd::AutogradContext* ctx, const torch::Tensor& lp_in,
                                                const Inputs& in, double weight) {
    const auto lp = lp_in.contiguous();
    const auto actions = in.actions.contiguous(), active = in.active.contiguous(),
               dist = in.target_dist.contiguous(), value = in.target_value.contiguous();
    EsTeamRows rows;
    rows.t = actions.size(0), rows.n_a = actions.size(1), rows.n_bins = lp.size(2);
    rows.actions = actions.data_ptr<int64_t>(), rows.active = active.data_ptr<bool>();
    rows.target_value = value.data_ptr<float>(), rows.target_dist = dist.data_ptr<float>(), rows.weight = weight;
    auto grad = torch::empty_like(lp);
    const EsLossSums r = es_d3_loss_rows(rows, lp.data_ptr<float>(), in.support, grad.data_ptr<float>());
    const double loss = r.loss, q = r.q, td = r.td, inv_valid = r.inv_valid;
    return team_loss_outputs(ctx, grad, loss, q, td, inv_valid, weight);
  }

  static torch::autograd::variable_list backward(torch::autograd::AutogradContext* ctx,
                                                 torch::autograd::variable_list grads) {
    // One gradient per forward input: log_probs, then none for the inputs and the weight.
    return {ctx->get_saved_variables()[0] * grads[0], torch::Tensor(), torch::Tensor()};
  }
};

// The checks both losses share: actions [T, n_a, 3] int64 with bins inside the critic's, active
// [T, n_a] bool, target_value [T], the critic's output with T * n_a rows of three axes.
void check_team_inputs(const char* name, const torch::Tensor& out, const torch::Tensor& actions,
                       const torch::Tensor& active, const torch::Tensor& target_value) {
  TORCH_CHECK(actions.dim() == 3 && actions.size(2) == 3 && actions.scalar_type() == torch::kInt64, name,
              ": actions must be int64 [T, n_a, 3]");
  const int64_t t = actions.size(0), n_a = actions.size(1);
  TORCH_CHECK(out.dim() >= 3 && out.size(0) == t * n_a && out.size(1) == 3 && out.scalar_type() == torch::kFloat32, name,
              ": the critic's output must be float [T * n_a, 3, n_bins, ...]");
  TORCH_CHECK(active.sizes() == torch::IntArrayRef({t, n_a}) && active.scalar_type() == torch::kBool, name,
              ": active must be bool [T, n_a]");
  TORCH_CHECK(target_value.sizes() == torch::IntArrayRef({t}), name, ": target_value must be [T]");
  const auto a = actions.contiguous();
  const int64_t* p = a.data_ptr<int64_t>();
  for (int64_t e = 0; e < a.numel(); ++e)
    TORCH_CHECK(p[e] >= 0 && p[e] < out.size(2), name, ": a bin is outside [0, n_bins)");
}

FusedEsLoss unpack(const torch::autograd::variable_list& out) {
  FusedEsLoss r;
  r.total = out[0];
  const double* s = out[1].data_ptr<double>();
  r.loss = s[0];
  r.q = s[1];
  r.td = s[2];
  return r;
}

}  // namespace

FusedEsLoss fused_es_d2_loss(const torch::Tensor& q, const torch::Tensor& actions, const torch::Tensor& active,
                             const torch::Tensor& target_value, double huber_delta, double weight) {
  check_team_inputs("fused_es_d2_loss", q, actions, active, target_value);
  TORCH_CHECK(q.dim() == 3, "fused_es_d2_loss: q must be [T * n_a, 3, n_bins]");
  TORCH_CHECK(huber_delta > 0.0, "fused_es_d2_loss: huber_delta must be > 0");
  const Inputs in{actions, active, torch::Tensor(), target_value.to(torch::kFloat32), C51Support{}};
  return unpack(EsD2LossNode::apply(q, in, huber_delta, weight));
}

FusedEsLoss fused_es_d3_loss(const torch::Tensor& log_probs, const torch::Tensor& actions, const torch::Tensor& active,
                             const torch::Tensor& target_dist, const torch::Tensor& target_value,
                             const C51Support& support, double weight) {
  check_team_inputs("fused_es_d3_loss", log_probs, actions, active, target_value);
  const int64_t t = actions.size(0);
  TORCH_CHECK(log_probs.dim() == 4 && log_probs.size(3) == support.n_atoms,
              "fused_es_d3_loss: log_probs must be float [T * n_a, 3, n_bins, n_atoms]");
  TORCH_CHECK(target_dist.sizes() == torch::IntArrayRef({t, support.n_atoms}),
              "fused_es_d3_loss: target_dist must be [T, n_atoms]");
  const Inputs in{actions, active, target_dist.to(torch::kFloat32), target_value.to(torch::kFloat32), support};
  return unpack(EsD3LossNode::apply(log_probs, in, weight));
}

}  // namespace f16race::agents
