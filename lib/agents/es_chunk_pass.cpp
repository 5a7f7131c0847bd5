#include "agents/es_chunk_pass.hpp"

#include <algorithm>
#include <cmath>

namespace f16race::agents {
namespace {

// log_probs = log_softmax of each group of k logits (HlCritic::from_head's), in double.
void log_softmax_groups(const float* x, int64_t groups, int64_t k, float* lp) {
  for (int64_t g = 0; g < groups; ++g) {
    const float* xg = x + g * k;
    const double top = *std::max_element(xg, xg + k);
    double sum = 0.0;
    for (int64_t c = 0; c < k; ++c) sum += std::exp(xg[c] - top);
    const double lse = top + std::log(sum);
    for (int64_t c = 0; c < k; ++c) lp[g * k + c] = static_cast<float>(xg[c] - lse);
  }
}

// The logits' gradient from the log-probabilities': d_x = d_lp - softmax * sum(d_lp), per group.
void log_softmax_backward(const float* lp, const float* d_lp, int64_t groups, int64_t k, float* d_x) {
  for (int64_t g = 0; g < groups; ++g) {
    const float *l = lp + g * k, *d = d_lp + g * k;
    double total = 0.0;
    for (int64_t c = 0; c < k; ++c) total += d[c];
    for (int64_t c = 0; c < k; ++c) d_x[g * k + c] = static_cast<float>(d[c] - std::exp(l[c]) * total);
  }
}

}  // namespace

EsLossSums EsChunkPass::run(const models::HlCriticImpl& net, const EsChunkRows& rows, double weight,
                            double huber_delta, const C51Support& support) {
  const auto& cfg = net.config();
  const int64_t t = rows.t, n_a = rows.n_a, b = t * n_a, width = net.head_width();
  const int64_t k = cfg.n_atoms;
  const std::vector<torch::Tensor> params = net.parameters();
  if (grads_.size() != params.size()) {
    grads_.clear();
    for (const auto& p : params) grads_.push_back(torch::empty_like(p, torch::MemoryFormat::Contiguous));
    grad_views_ = net.train_grads(grads_);
  }
  index_.resize(static_cast<std::size_t>(b));
  actions_.resize(static_cast<std::size_t>(b * 3));
  if (active_capacity_ < b) {
    active_ = std::make_unique<bool[]>(static_cast<std::size_t>(b));
    active_capacity_ = b;
  }
  target_value_.resize(static_cast<std::size_t>(t));
  target_dist_.resize(static_cast<std::size_t>(k > 1 ? t * k : 0));
  for (int64_t r = 0; r < t; ++r) {  // the chunk's teams, gathered: their rows, actions and targets
    const int64_t s = rows.teams[r];
    for (int64_t i = 0; i < n_a; ++i) index_[r * n_a + i] = s * n_a + i;
    std::copy_n(rows.actions + s * n_a * 3, n_a * 3, actions_.data() + r * n_a * 3);
    std::copy_n(rows.active + s * n_a, n_a, active_.get() + r * n_a);
    target_value_[r] = rows.target_value[s];
    if (k > 1) std::copy_n(rows.target_dist + s * k, k, target_dist_.data() + r * k);
  }
  const models::HlObs& o = *rows.obs;
  models::kernels::TrainRows in;
  in.ego = o.ego.data_ptr<float>(), in.goal = o.prev_action.data_ptr<float>(), in.ado = o.ado.data_ptr<float>();
  in.ado_alive = o.ado_alive.data_ptr<bool>(), in.task = o.task.data_ptr<float>(), in.index = index_.data();
  const models::kernels::AttentionMlpTrainNet view = net.train_net();
  out_.resize(static_cast<std::size_t>(b * width));
  d_out_.resize(out_.size());
  pass_.forward(view, b, in, out_.data(), nullptr);

  EsTeamRows team;
  team.t = t, team.n_a = n_a, team.n_bins = cfg.n_bins;
  team.actions = actions_.data(), team.active = active_.get(), team.target_value = target_value_.data();
  team.target_dist = k > 1 ? target_dist_.data() : nullptr, team.weight = weight;
  EsLossSums sums;
  if (k == 1) {
    sums = es_d2_loss_rows(team, out_.data(), huber_delta, d_out_.data());
  } else {
    log_probs_.resize(out_.size());
    d_log_probs_.resize(out_.size());
    const int64_t groups = b * width / k;
    log_softmax_groups(out_.data(), groups, k, log_probs_.data());
    sums = es_d3_loss_rows(team, log_probs_.data(), support, d_log_probs_.data());
    log_softmax_backward(log_probs_.data(), d_log_probs_.data(), groups, k, d_out_.data());
  }
  pass_.backward(view, d_out_.data(), nullptr, grad_views_);
  return sums;
}

}  // namespace f16race::agents
