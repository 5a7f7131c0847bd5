#include "agents/rollout_buffer.hpp"

namespace f16race::agents {

using models::check_tensor;

GaeResult compute_gae(const torch::Tensor& rewards, const torch::Tensor& values, const torch::Tensor& terminated,
                      const torch::Tensor& truncated, const torch::Tensor& bootstrap_values,
                      const torch::Tensor& last_value, double gamma, double gae_lambda) {
  check_tensor(rewards, "rewards", {-1, -1}, torch::kFloat32);
  const int64_t t_max = rewards.size(0), n = rewards.size(1);
  check_tensor(values, "values", {t_max, n}, torch::kFloat32);
  check_tensor(terminated, "terminated", {t_max, n}, torch::kBool);
  check_tensor(truncated, "truncated", {t_max, n}, torch::kBool);
  check_tensor(bootstrap_values, "bootstrap_values", {t_max, n}, torch::kFloat32);
  check_tensor(last_value, "last_value", {n}, torch::kFloat32);
  torch::NoGradGuard no_grad;
  auto advantages = torch::zeros({t_max, n});
  auto next_advantage = torch::zeros({n});
  auto next_value = last_value;
  for (int64_t t = t_max - 1; t >= 0; --t) {
    const auto term = terminated[t];
    const auto trunc = truncated[t].logical_and(term.logical_not());
    const auto v_next = torch::where(term, torch::zeros({n}), torch::where(trunc, bootstrap_values[t], next_value));
    const auto delta = rewards[t] + gamma * v_next - values[t];
    const auto carry = term.logical_or(trunc).logical_not().to(torch::kFloat32);
    next_advantage = delta + gamma * gae_lambda * carry * next_advantage;
    advantages[t] = next_advantage;
    next_value = values[t];
  }
  return {advantages, advantages + values};
}

RolloutBuffer::RolloutBuffer(int64_t n_steps, int64_t n_samples, const models::ObsDims& dims, int64_t action_dim)
    : n_steps_(n_steps), n_samples_(n_samples), action_dim_(action_dim), dims_(dims) {
  TORCH_CHECK(n_steps > 0 && n_samples > 0, "RolloutBuffer: n_steps and n_samples must be > 0");
  const int64_t t = n_steps, n = n_samples;
  obs.ego = torch::zeros({t, n, dims.d_ego});
  obs.goal = torch::zeros({t, n, 3});
  obs.ado = torch::zeros({t, n, dims.n_other, dims.d_ado});
  obs.ado_alive = torch::zeros({t, n, dims.n_other}, torch::kBool);
  obs.task = torch::zeros({t, n, dims.d_task});
  actions = torch::zeros({t, n, action_dim});
  log_probs = torch::zeros({t, n});
  values = torch::zeros({t, n});
  rewards = torch::zeros({t, n});
  terminated = torch::zeros({t, n}, torch::kBool);
  truncated = torch::zeros({t, n}, torch::kBool);
  bootstrap_values = torch::zeros({t, n});
  valid = torch::ones({t, n}, torch::kBool);
}

void RolloutBuffer::stage_picked(const models::LlObs& o, const torch::Tensor& action, const torch::Tensor& log_prob,
                                 const torch::Tensor& value, const torch::Tensor& rows) {
  TORCH_CHECK(size_ < n_steps_, "RolloutBuffer::stage_picked: buffer is full (", n_steps_, " steps)");
  const int64_t n = n_samples_, b = models::check_obs(o, dims_);
  check_tensor(rows, "rows", {n}, torch::kInt64);
  check_tensor(action, "action", {b, action_dim_}, torch::kFloat32);
  check_tensor(log_prob, "log_prob", {b}, torch::kFloat32);
  check_tensor(value, "value", {b}, torch::kFloat32);
  torch::NoGradGuard no_grad;
  const int64_t t = size_;
  auto gather = [&](const torch::Tensor& src, torch::Tensor slot) { torch::index_select_out(slot, src, 0, rows); };
  gather(o.ego, obs.ego[t]);
  gather(o.goal, obs.goal[t]);
  gather(o.ado, obs.ado[t]);
  gather(o.ado_alive, obs.ado_alive[t]);
  gather(o.task, obs.task[t]);
  gather(action, actions[t]);
  gather(log_prob, log_probs[t]);
  gather(value, values[t]);
  staged_ = true;
}

void RolloutBuffer::commit(const torch::Tensor& reward, const torch::Tensor& term, const torch::Tensor& trunc,
                           const torch::Tensor& bootstrap_value, const torch::Tensor& valid_mask) {
  TORCH_CHECK(staged_, "RolloutBuffer::commit: no staged step (call stage_picked first)");
  check_step_fields(reward, term, trunc, bootstrap_value, valid_mask);
  staged_ = false;
  add_step_fields(reward, term, trunc, bootstrap_value, valid_mask);
}

void RolloutBuffer::add(const models::LlObs& o, const torch::Tensor& action, const torch::Tensor& log_prob,
                        const torch::Tensor& value, const torch::Tensor& reward, const torch::Tensor& term,
                        const torch::Tensor& trunc, const torch::Tensor& bootstrap_value,
                        const torch::Tensor& valid_mask) {
  TORCH_CHECK(size_ < n_steps_, "RolloutBuffer::add: buffer is full (", n_steps_, " steps)");
  const int64_t n = n_samples_;
  TORCH_CHECK(models::check_obs(o, dims_) == n, "RolloutBuffer::add: obs batch must be n_samples = ", n);
  check_tensor(action, "action", {n, action_dim_}, torch::kFloat32);
  check_tensor(log_prob, "log_prob", {n}, torch::kFloat32);
  check_tensor(value, "value", {n}, torch::kFloat32);
  check_step_fields(reward, term, trunc, bootstrap_value, valid_mask);
  torch::NoGradGuard no_grad;
  const int64_t t = size_;
  staged_ = false;
  obs.ego[t].copy_(o.ego);
  obs.goal[t].copy_(o.goal);
  obs.ado[t].copy_(o.ado);
  obs.ado_alive[t].copy_(o.ado_alive);
  obs.task[t].copy_(o.task);
  actions[t].copy_(action);
  log_probs[t].copy_(log_prob);
  values[t].copy_(value);
  add_step_fields(reward, term, trunc, bootstrap_value, valid_mask);
}

void RolloutBuffer::check_step_fields(const torch::Tensor& reward, const torch::Tensor& term,
                                      const torch::Tensor& trunc, const torch::Tensor& bootstrap_value,
                                      const torch::Tensor& valid_mask) const {
  const int64_t n = n_samples_;
  check_tensor(reward, "reward", {n}, torch::kFloat32);
  check_tensor(term, "terminated", {n}, torch::kBool);
  check_tensor(trunc, "truncated", {n}, torch::kBool);
  if (bootstrap_value.defined())
    check_tensor(bootstrap_value, "bootstrap_value", {n}, torch::kFloat32);
  else
    TORCH_CHECK(!trunc.any().item<bool>(), "RolloutBuffer::add: truncated samples need a bootstrap_value");
  if (valid_mask.defined()) check_tensor(valid_mask, "valid", {n}, torch::kBool);
}

void RolloutBuffer::add_step_fields(const torch::Tensor& reward, const torch::Tensor& term, const torch::Tensor& trunc,
                                    const torch::Tensor& bootstrap_value, const torch::Tensor& valid_mask) {
  const int64_t t = size_;
  torch::NoGradGuard no_grad;
  rewards[t].copy_(reward);
  terminated[t].copy_(term);
  truncated[t].copy_(trunc);
  if (bootstrap_value.defined())
    bootstrap_values[t].copy_(bootstrap_value);
  else
    bootstrap_values[t].zero_();
  if (valid_mask.defined())
    valid[t].copy_(valid_mask);
  else
    valid[t].fill_(true);
  ++size_;
  finished_ = false;
}

void RolloutBuffer::finish(const torch::Tensor& last_value, double gamma, double gae_lambda) {
  TORCH_CHECK(full(), "RolloutBuffer::finish: only ", size_, " of ", n_steps_, " steps stored");
  const auto gae = compute_gae(rewards, values, terminated, truncated, bootstrap_values, last_value, gamma, gae_lambda);
  advantages = gae.advantages;
  returns = gae.returns;
  finished_ = true;
}

}  // namespace f16race::agents
