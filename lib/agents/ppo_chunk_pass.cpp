#include "agents/ppo_chunk_pass.hpp"

#include <algorithm>

#include "agents/ppo_fused_loss.hpp"

namespace f16race::agents {

std::array<double, 5> PpoChunkPass::run(const models::LlActorCriticImpl& net, const PpoChunkRows& rows,
                                        double weight, const PpoLossCoefs& coefs) {
  const int64_t m = rows.m, a_dim = net.config().action_dim;
  const std::vector<torch::Tensor> params = net.parameters();
  if (grads_.size() != params.size()) {
    grads_.clear();
    for (const auto& p : params) grads_.push_back(torch::empty_like(p, torch::MemoryFormat::Contiguous));
    grad_views_ = net.train_grads(grads_);
    for (std::size_t i = 0; i < params.size(); ++i)
      if (params[i].is_same(net.log_std())) log_std_slot_ = i;
  }
  const auto size = static_cast<std::size_t>(m);
  index_.resize(size);
  for (auto* v : {&mean_, &d_mean_, &action_}) v->resize(size * static_cast<std::size_t>(a_dim));
  for (auto* v : {&value_, &d_value_, &old_log_prob_, &old_value_, &returns_}) v->resize(size);
  for (int64_t i = 0; i < m; ++i) {  // the chunk's constants, gathered from the valid rows
    const int64_t p = rows.positions[i];
    index_[i] = rows.valid_rows[p];
    std::copy_n(rows.actions + p * a_dim, a_dim, action_.data() + i * a_dim);
    old_log_prob_[i] = rows.old_log_probs[p];
    old_value_[i] = rows.old_values[p];
    returns_[i] = rows.returns[p];
  }
  const models::LlObs& o = *rows.obs;
  models::kernels::TrainRows in;
  in.ego = o.ego.data_ptr<float>(), in.goal = o.goal.data_ptr<float>(), in.ado = o.ado.data_ptr<float>();
  in.ado_alive = o.ado_alive.data_ptr<bool>(), in.task = o.task.data_ptr<float>(), in.index = index_.data();
  const models::kernels::AttentionMlpTrainNet view = net.train_net();
  pass_.forward(view, m, in, mean_.data(), value_.data());

  const torch::Tensor& log_std = net.log_std();
  PpoLossRows loss;
  loss.m = m, loss.a_dim = a_dim;
  loss.mean = mean_.data(), loss.log_std = log_std.data_ptr<float>(), loss.log_std_row_stride = 0;
  loss.value = value_.data(), loss.action = action_.data(), loss.old_log_prob = old_log_prob_.data();
  loss.advantages = rows.advantages, loss.old_value = old_value_.data(), loss.returns = returns_.data();
  loss.clip = coefs.clip, loss.clip_value = coefs.clip_value, loss.vf_coef = coefs.vf_coef;
  loss.ent_coef = coefs.ent_coef, loss.weight = weight;
  d_log_std_.resize(static_cast<std::size_t>(a_dim));
  PpoLossGrads g;
  g.d_mean = d_mean_.data(), g.d_value = d_value_.data(), g.d_log_std_sum = d_log_std_.data();
  const std::array<double, 5> terms = ppo_loss_rows(loss, g);

  pass_.backward(view, d_mean_.data(), d_value_.data(), grad_views_);
  float* dst = grads_[log_std_slot_].data_ptr<float>();
  for (int64_t j = 0; j < a_dim; ++j) dst[j] = static_cast<float>(d_log_std_[static_cast<std::size_t>(j)]);
  return terms;
}

}  // namespace f16race::agents
