#include "agents/expected_sarsa.hpp"

#include <algorithm>
#include <cmath>
#include <stdexcept>

#include "agents/checkpoint.hpp"
#include "agents/es_fused_loss.hpp"

namespace f16race::agents {

using models::check_tensor;

EsVariant parse_es_variant(const std::string& name) {
  if (name == "es") return EsVariant::kEs;
  if (name == "es_d1") return EsVariant::kEsD1;
  if (name == "es_d2") return EsVariant::kEsD2;
  if (name == "es_d3") return EsVariant::kEsD3;
  throw std::invalid_argument("unknown ES variant '" + name + "' (expected es, es_d1, es_d2 or es_d3)");
}

const char* es_variant_name(EsVariant v) {
  switch (v) {
    case EsVariant::kEs: return "es";
    case EsVariant::kEsD1: return "es_d1";
    case EsVariant::kEsD2: return "es_d2";
    case EsVariant::kEsD3: return "es_d3";
  }
  return "?";
}

models::HlCriticConfig es_critic_config(const EsConfig& cfg) {
  models::HlCriticConfig c;
  c.dims = cfg.dims;
  c.d_model = cfg.d_model;
  c.n_heads = cfg.n_heads;
  c.hidden = cfg.hidden;
  c.decoupled = es_is_decoupled(cfg.variant);
  c.n_bins = cfg.n_bins;
  c.n_atoms = cfg.variant == EsVariant::kEsD3 ? cfg.n_atoms : 1;
  c.v_min = cfg.v_min;
  c.v_max = cfg.v_max;
  return c;
}

torch::Tensor egreedy_value_joint(const torch::Tensor& q, double eps) {
  check_tensor(q, "q", {-1, -1}, torch::kFloat32);
  const int64_t n = q.size(0);
  const int64_t nb = static_cast<int64_t>(std::lround(std::cbrt(static_cast<double>(q.size(1)))));
  TORCH_CHECK(nb * nb * nb == q.size(1), "egreedy_value_joint: q has ", q.size(1), " columns, not n_bins^3");
  // Per-dimension policy (1 - eps) onehot(greedy_j) + eps / n_bins, greedy from the joint argmax.
  const auto greedy = decode_joint_index(q.argmax(1), nb);  // [N, 3]
  const auto pi = (1.0 - eps) * torch::one_hot(greedy, nb).to(torch::kFloat32) + eps / static_cast<double>(nb);
  return torch::einsum("nabc,na,nb,nc->n", {q.view({n, nb, nb, nb}), pi.select(1, 0), pi.select(1, 1), pi.select(1, 2)});
}

torch::Tensor egreedy_value_per_axis(const torch::Tensor& q, double eps) {
  check_tensor(q, "q", {-1, 3, -1}, torch::kFloat32);
  // The eps-greedy value over the bins: (1 - eps) max + eps mean.
  return (1.0 - eps) * std::get<0>(q.max(-1)) + eps * q.mean(-1);
}

torch::Tensor egreedy_value_decoupled(const torch::Tensor& q, double eps) {
  return egreedy_value_per_axis(q, eps).mean(1);
}

torch::Tensor egreedy_mixture_decoupled(const torch::Tensor& log_probs, const torch::Tensor& q, double eps) {
  check_tensor(q, "q", {-1, 3, -1}, torch::kFloat32);
  const int64_t n = q.size(0), bins = q.size(2);
  check_tensor(log_probs, "log_probs", {n, 3, bins, -1}, torch::kFloat32);
  const auto probs = log_probs.exp();  // [N, 3, bins, K]
  const auto greedy = q.argmax(2);     // [N, 3], first maximum as in act()
  const auto index = greedy.view({n, 3, 1, 1}).expand({n, 3, 1, probs.size(3)});
  const auto p_greedy = probs.gather(2, index).squeeze(2);  // [N, 3, K]
  return ((1.0 - eps) * p_greedy + eps * probs.mean(2)).mean(1);
}

torch::Tensor decode_joint_index(const torch::Tensor& index, int64_t n_bins) {
  return torch::stack({index.div(n_bins * n_bins, "floor"), index.div(n_bins, "floor").remainder(n_bins),
                       index.remainder(n_bins)},
                      -1);
}

torch::Tensor joint_index(const torch::Tensor& bins, int64_t n_bins) {
  TORCH_CHECK(bins.dim() >= 1 && bins.size(-1) == 3, "joint_index: bins must end in a dimension of 3");
  return bins.select(-1, 0) * (n_bins * n_bins) + bins.select(-1, 1) * n_bins + bins.select(-1, 2);
}

namespace {

// Mean over the aircraft axis (1) of x [T, n_a, ...] restricted to mask [T, n_a]; also returns
// the count of mask entries per team.
std::pair<torch::Tensor, torch::Tensor> masked_team_mean(const torch::Tensor& x, const torch::Tensor& mask) {
  auto m = mask.to(torch::kFloat32);
  const auto count = m.sum(1);
  while (m.dim() < x.dim()) m = m.unsqueeze(-1);
  auto denom = count.clamp_min(1.0);
  while (denom.dim() < x.dim() - 1) denom = denom.unsqueeze(-1);
  return {(x * m).sum(1) / denom, count};
}

torch::Tensor masked_mean(const torch::Tensor& x, const torch::Tensor& mask) {
  const auto m = mask.to(torch::kFloat32);
  return (x * m).sum() / m.sum().clamp_min(1.0);
}

}  // namespace

EsTarget es_target(EsVariant v, const models::HlOutput& next_out, const torch::Tensor& reward,
                   const torch::Tensor& done, const torch::Tensor& active, const torch::Tensor& next_active,
                   double next_epsilon, double gamma, const C51Support& support) {
  check_tensor(reward, "reward", {-1, -1}, torch::kFloat32);
  const int64_t t = reward.size(0), n_a = reward.size(1);
  check_tensor(done, "done", {t}, torch::kBool);
  check_tensor(active, "active", {t, n_a}, torch::kBool);
  check_tensor(next_active, "next_active", {t, n_a}, torch::kBool);
  TORCH_CHECK(next_out.q.defined() && next_out.q.size(0) == t * n_a, "es_target: next_out.q must have T*n_a = ",
              t * n_a, " rows");
  EsTarget target;
  if (!es_is_team(v)) {
    const auto next_value = (v == EsVariant::kEs ? egreedy_value_joint(next_out.q, next_epsilon)
                                                 : egreedy_value_decoupled(next_out.q, next_epsilon))
                                .view({t, n_a});
    // An aircraft that is dead at the next decision ends its own episode there.
    const auto live = next_active.logical_and(done.logical_not().unsqueeze(1)).to(torch::kFloat32);
    target.value = reward + gamma * live * next_value;
    return target;
  }
  const auto team_reward = masked_team_mean(reward, active).first;
  const auto team_live = done.logical_not().logical_and(next_active.any(1)).to(torch::kFloat32);
  if (v == EsVariant::kEsD2) {
    const auto next_value = egreedy_value_decoupled(next_out.q, next_epsilon).view({t, n_a});
    const auto team_next = masked_team_mean(next_value, next_active).first;
    target.value = team_reward + gamma * team_live * team_next;
    return target;
  }
  TORCH_CHECK(next_out.log_probs.defined(), "es_target: es_d3 needs the distributional head (log_probs)");
  const int64_t k = support.n_atoms;
  const auto mixture = egreedy_mixture_decoupled(next_out.log_probs, next_out.q, next_epsilon).view({t, n_a, k});
  auto team_mix = masked_team_mean(mixture, next_active).first;  // [T, K]
  // With nobody alive next the discount is 0 and any distribution projects to r; use a
  // normalised one so no mass is lost.
  team_mix = torch::where(next_active.any(1, true), team_mix, torch::full_like(team_mix, 1.0 / k));
  target.dist = c51_project(team_mix.contiguous(), team_reward.contiguous(), (gamma * team_live).contiguous(), support);
  target.value = (target.dist * support.atoms()).sum(1);
  return target;
}

EsLoss es_loss(EsVariant v, const models::HlOutput& out, const torch::Tensor& actions, const torch::Tensor& active,
               const EsTarget& target, double huber_delta, const C51Support& support, double component_ce_weight,
               D3Loss d3_loss) {
  check_tensor(actions, "actions", {-1, -1, 3}, torch::kInt64);
  const int64_t t = actions.size(0), n_a = actions.size(1);
  check_tensor(active, "active", {t, n_a}, torch::kBool);
  EsLoss result;
  const auto huber = [&](const torch::Tensor& pred, const torch::Tensor& y, const torch::Tensor& valid) {
    return masked_mean(torch::huber_loss(pred, y, at::Reduction::None, huber_delta), valid);
  };
  if (v == EsVariant::kEs) {
    const int64_t n_joint = out.q.size(1);
    const int64_t n_bins = static_cast<int64_t>(std::lround(std::cbrt(static_cast<double>(n_joint))));
    const auto idx = joint_index(actions, n_bins).view({t * n_a, 1});
    result.prediction = out.q.gather(1, idx).view({t, n_a});
    result.valid = active;
    result.loss = huber(result.prediction, target.value, result.valid);
    return result;
  }
  const auto idx = actions.reshape({t * n_a, 3, 1});
  const auto q_taken = out.q.gather(2, idx).squeeze(2).mean(1).view({t, n_a});  // mean_j Q^j(a^j)
  if (v == EsVariant::kEsD1) {
    result.prediction = q_taken;
    result.valid = active;
    result.loss = huber(result.prediction, target.value, result.valid);
    return result;
  }
  result.valid = active.any(1);
  if (v == EsVariant::kEsD2) {
    result.prediction = masked_team_mean(q_taken, active).first;
    result.loss = huber(result.prediction, target.value, result.valid);
    return result;
  }
  // es_d3: log of the team mixture, log(1/(3 n_active) sum_{i active, j} p^{i,j}), by logsumexp.
  const int64_t k = support.n_atoms;
  TORCH_CHECK(out.log_probs.defined() && out.log_probs.size(-1) == k, "es_loss: es_d3 needs log_probs with ", k,
              " atoms");
  TORCH_CHECK(target.dist.defined(), "es_loss: es_d3 needs a target distribution");
  const auto lp_idx = actions.reshape({t * n_a, 3, 1, 1}).expand({t * n_a, 3, 1, k});
  const auto lp_taken = out.log_probs.gather(2, lp_idx).squeeze(2).view({t, n_a, 3, k});
  // Finite fill (not -inf) so teams without any active aircraft stay free of NaN; they are
  // excluded from the loss by `valid`.
  const auto lp = lp_taken.masked_fill(active.logical_not().view({t, n_a, 1, 1}), -1e4);
  const auto n_terms = (3.0 * active.to(torch::kFloat32).sum(1)).clamp_min(1.0);
  const auto log_team = torch::logsumexp(lp.view({t, n_a * 3, k}), 1) - n_terms.log().unsqueeze(1);  // [T, K]
  result.prediction = (log_team.exp() * support.atoms()).sum(1);
  if (d3_loss == D3Loss::kHuberMean) {  // Eq. 5 on the mixture's mean: the target's mean is y_t
    result.loss = huber(result.prediction, target.value, result.valid);
    return result;
  }
  const auto cross_entropy = -(target.dist * log_team).sum(1);
  result.loss = masked_mean(cross_entropy, result.valid);
  if (component_ce_weight > 0.0) {
    // Each active component's own cross-entropy to the team target (an upper bound of the
    // mixture's, by Jensen) keeps components that explain none of the target trainable.
    const auto component_ce = -(target.dist.view({t, 1, 1, k}) * lp_taken).sum(3).mean(2);  // [T, n_a]
    result.loss = result.loss + component_ce_weight * masked_mean(component_ce, active);
  }
  return result;
}

EsAgent::EsAgent(const EsConfig& cfg)
    : cfg_(cfg),
      support_{cfg.v_min, cfg.v_max, cfg.n_atoms},
      generator_(models::make_generator(cfg.seed)) {
  TORCH_CHECK(cfg.epsilon >= 0.0 && cfg.epsilon <= 1.0, "EsConfig.epsilon must be in [0, 1]");
  TORCH_CHECK(cfg.target_update_interval > 0 && cfg.n_epochs > 0 && cfg.n_minibatches > 0,
              "EsConfig: target_update_interval, n_epochs, n_minibatches must be > 0");
  const auto critic_cfg = es_critic_config(cfg);
  critic_ = models::HlCritic(critic_cfg);
  target_ = models::HlCritic(critic_cfg);
  normalizer_ = models::ObsNormalizer(cfg.dims, cfg.obs_clip);
  for (auto& p : target_->parameters()) p.set_requires_grad(false);
  sync_target();
  optimizer_ = std::make_unique<torch::optim::Adam>(
      critic_->parameters(), torch::optim::AdamOptions(cfg.learning_rate).eps(cfg.adam_eps));
  if (cfg.eigen_inference) {
    eigen_.follow(critic_->parameters(), [critic = critic_] { return critic->eigen_weights(); });
    target_eigen_.follow(target_->parameters(), [target = target_] { return target->eigen_weights(); });
  }
}

void EsAgent::sync_target() {
  torch::NoGradGuard no_grad;
  const auto src = critic_->named_parameters();
  for (auto& item : target_->named_parameters()) item.value().copy_(src[item.key()]);
  const auto src_buf = critic_->named_buffers();
  for (auto& item : target_->named_buffers()) item.value().copy_(src_buf[item.key()]);
}

models::HlObs EsAgent::prepare(const models::HlObs& flat_obs, bool update_stats) {
  return cfg_.normalize_obs ? normalizer_->normalize(flat_obs, update_stats) : flat_obs;
}

EsAction EsAgent::act(const models::HlObs& obs, double epsilon, at::Generator& generator) {
  return choose(q_values(obs), epsilon, generator);
}

EsAction EsAgent::act(const models::HlObs& obs, const torch::Tensor& rows, double epsilon, at::Generator& generator) {
  return choose(q_values(obs, rows), epsilon, generator);
}

torch::Tensor EsAgent::q_values(const models::HlObs& obs, const torch::Tensor& rows) {
  if (!eigen_.following() || !cfg_.normalize_obs) return q_values(models::index_rows(obs, rows));
  torch::NoGradGuard no_grad;
  models::check_obs(obs, cfg_.dims);
  check_tensor(rows, "rows", {-1}, torch::kInt64);
  const int64_t b = rows.numel();
  const auto& d = cfg_.dims;
  // The picked rows, normalised by the forward's blocks into `normalised` (the same float
  // arithmetic as the normaliser's: kernels::normalize_row), then the same forward as q_values.
  const models::HlObs fields{obs.ego.contiguous(), obs.prev_action.contiguous(), obs.ado.contiguous(),
                             obs.ado_alive.contiguous(), obs.task.contiguous()};
  const models::HlObs normalised{torch::empty({b, d.d_ego}), torch::empty({b, d.d_prev_action}),
                                 torch::empty({b, d.n_other, d.d_ado}), torch::empty({b, d.n_other}, torch::kBool),
                                 torch::empty({b, d.d_task})};
  const auto index = rows.contiguous();
  const models::LlRawRows r = normalizer_->raw_rows(fields, index, normalised, &norm_terms_);
  auto head = torch::empty({b, critic_->head_width()});
  eigen_.current().forward(b, r, head.data_ptr<float>(), nullptr);
  return critic_->from_head(head).q;
}

torch::Tensor EsAgent::q_values(const models::HlObs& obs) {
  torch::NoGradGuard no_grad;
  models::check_obs(obs, cfg_.dims);
  return forward_no_grad(false, prepare(obs, false)).q;
}

models::HlOutput EsAgent::forward_no_grad(bool target, const models::HlObs& n) {
  torch::NoGradGuard no_grad;
  models::HlCritic& net = target ? target_ : critic_;
  EigenMirror& mirror = target ? target_eigen_ : eigen_;
  if (!mirror.following()) return net(n);
  const int64_t b = n.ego.size(0);
  const auto ego = n.ego.contiguous(), prev = n.prev_action.contiguous(), ado = n.ado.contiguous(),
             alive = n.ado_alive.contiguous(), task = n.task.contiguous();
  auto head = torch::empty({b, net->head_width()});
  mirror.current().forward(b, ego.data_ptr<float>(), prev.data_ptr<float>(), ado.data_ptr<float>(), alive.data_ptr<bool>(),
                           task.data_ptr<float>(), head.data_ptr<float>(), nullptr);
  return net->from_head(head);
}

EsAction EsAgent::choose(const torch::Tensor& q, double epsilon, at::Generator& generator) const {
  torch::NoGradGuard no_grad;
  const int64_t b = q.size(0);
  EsAction a;
  a.q = q;
  a.greedy_bins = es_is_decoupled(cfg_.variant) ? q.argmax(2) : decode_joint_index(q.argmax(1), cfg_.n_bins);
  // One coin per aircraft and action dimension (see the header: keeps the other dimensions greedy
  // while one explores, so a dimension's value is not confounded by the others' exploration).
  const auto explore = torch::rand({b, 3}, generator) < epsilon;
  const auto random_bins = torch::randint(0, cfg_.n_bins, {b, 3}, generator, torch::kInt64);
  a.bins = torch::where(explore, random_bins, a.greedy_bins);
  return a;
}

void es_policy_diagnostics(const torch::Tensor& q, int64_t n_bins, EsStats* stats) {
  torch::NoGradGuard no_grad;
  const int64_t n = q.size(0);
  if (n == 0) return;
  const bool decoupled = q.dim() == 3;
  const auto greedy = decoupled ? q.argmax(2) : decode_joint_index(q.argmax(1), n_bins);  // [N, 3]
  const auto spread = decoupled ? (std::get<0>(q.max(2)) - std::get<0>(q.min(2))).mean()
                                : (std::get<0>(q.max(1)) - std::get<0>(q.min(1))).mean();
  stats->q_spread = spread.item<double>();
  const auto share = torch::one_hot(greedy, n_bins).to(torch::kFloat64).mean(0);  // [3, n_bins]
  const auto entropy = -(share * share.clamp_min(1e-300).log()).sum(1).mean();
  stats->greedy_entropy = n_bins > 1 ? entropy.item<double>() / std::log(static_cast<double>(n_bins)) : 0.0;
  stats->off_center_share = (greedy != n_bins / 2).any(1).to(torch::kFloat64).mean().item<double>();
  const auto middle = (greedy == n_bins / 2).to(torch::kFloat64).mean(0).contiguous();  // [3]
  for (int j = 0; j < 3; ++j) stats->middle_share[j] = middle.data_ptr<double>()[j];
}

namespace {

// The masks of `batch` (all true where undefined), its shapes checked: active, next_active [T, n_a].
std::pair<torch::Tensor, torch::Tensor> checked_masks(const EsBatch& batch) {
  check_tensor(batch.actions, "actions", {-1, -1, 3}, torch::kInt64);
  const int64_t t = batch.actions.size(0), n_a = batch.actions.size(1);
  check_tensor(batch.reward, "reward", {t, n_a}, torch::kFloat32);
  check_tensor(batch.done, "done", {t}, torch::kBool);
  const auto all = torch::ones({t, n_a}, torch::kBool);
  const auto active = batch.active.defined() ? batch.active : all;
  const auto next_active = batch.next_active.defined() ? batch.next_active : all;
  check_tensor(active, "active", {t, n_a}, torch::kBool);
  check_tensor(next_active, "next_active", {t, n_a}, torch::kBool);
  TORCH_CHECK(batch.obs.ego.dim() == 3 && batch.obs.ego.size(0) == t && batch.obs.ego.size(1) == n_a,
              "EsBatch.obs.ego must be [T, n_a, d_ego] with T, n_a of actions");
  TORCH_CHECK(batch.next_obs.ego.dim() == 3 && batch.next_obs.ego.size(0) == t && batch.next_obs.ego.size(1) == n_a,
              "EsBatch.next_obs.ego must be [T, n_a, d_ego]");
  return {active, next_active};
}

// Other aircraft alive per team (its n_a rows of ado_alive): the passes' alive share, for bench
// train's floor.
std::vector<int64_t> team_alive_counts(const torch::Tensor& ado_alive, int64_t t, int64_t n_a) {
  std::vector<int64_t> team_alive(static_cast<std::size_t>(t), 0);
  const std::vector<int64_t> per_row = models::alive_per_row(ado_alive);
  for (int64_t r = 0; r < t * n_a; ++r) team_alive[static_cast<std::size_t>(r / n_a)] += per_row[static_cast<std::size_t>(r)];
  return team_alive;
}

}  // namespace

// What every gradient step of one update reads.
struct EsAgent::UpdateData {
  const EsBatch& batch;
  const models::HlObs& obs;  // normalised, [T * n_a] rows, contiguous
  const torch::Tensor& active;
  const EsTarget& target;
  int64_t n_a;
  const bool* active_host;  // active, contiguous on the host
  torch::Tensor aircraft;   // arange(n_a)
  std::vector<int64_t> team_alive;
  // The fused pass's reads, contiguous: actions [T, n_a, 3], the target's value [T] and dist [T, K].
  torch::Tensor actions, target_value, target_dist;
};

EsStats EsAgent::update(const EsBatch& batch) {
  const auto masks = checked_masks(batch);
  const torch::Tensor& active = masks.first;
  const int64_t t = batch.actions.size(0), n_a = batch.actions.size(1);
  const auto flat_obs = models::flatten2(batch.obs);
  if (cfg_.normalize_obs) {
    // Statistics from the aircraft that took the decision only (dead ones hold stale states).
    normalizer_->normalize(models::index_rows(flat_obs, active.reshape({-1}).nonzero().squeeze(1)), true);
    normalizer_->sync_replicas();  // replicas: every rank's batch, before it is normalised
  }
  const models::HlObs prepared = prepare(flat_obs, false);
  const models::HlObs obs{prepared.ego.contiguous(), prepared.prev_action.contiguous(), prepared.ado.contiguous(),
                          prepared.ado_alive.contiguous(), prepared.task.contiguous()};
  EsTarget target;
  EsStats stats;
  // A replica with no transition this time (t = 0) only joins the group's steps below.
  if (t > 0) {
    torch::NoGradGuard no_grad;
    const auto next_out = forward_no_grad(true, prepare(models::flatten2(batch.next_obs), false));
    target = es_target(cfg_.variant, next_out, batch.reward, batch.done, active, masks.second, batch.next_epsilon,
                       cfg_.gamma, support_);
    measure_before_steps(obs, batch, active, target, &stats);
  }
  const auto active_contiguous = active.contiguous();
  const UpdateData d{batch,
                     obs,
                     active,
                     target,
                     n_a,
                     active_contiguous.data_ptr<bool>(),
                     torch::arange(n_a, torch::kInt64),
                     team_alive_counts(flat_obs.ado_alive, t, n_a),
                     batch.actions.contiguous(),
                     target.value.defined() ? target.value.to(torch::kFloat32).contiguous() : torch::Tensor(),
                     target.dist.defined() ? target.dist.to(torch::kFloat32).contiguous() : torch::Tensor()};
  double loss_sum = 0.0, q_sum = 0.0, td_sum = 0.0;
  int64_t n_steps = 0;
  for (int64_t epoch = 0; epoch < cfg_.n_epochs; ++epoch) {
    const auto perm = torch::randperm(t, generator_, torch::kInt64);
    for (const auto& teams : perm.tensor_split(cfg_.n_minibatches)) {
      if (teams.numel() == 0 && !replicas_.active()) continue;
      const GradientStepResult step = minibatch_step(d, teams, &stats);
      if (!step.stepped) continue;
      loss_sum += step.terms[0];
      q_sum += step.terms[1];
      td_sum += step.terms[2];
      ++n_steps;
    }
  }
  ++update_count_;
  stats.update_index = update_count_;
  if (update_count_ % cfg_.target_update_interval == 0) {
    sync_target();
    stats.target_synced = true;
  }
  const double n = static_cast<double>(std::max<int64_t>(n_steps, 1));
  stats.grad_steps = n_steps;
  stats.forward_rows = 2 * t * n_a;  // the target network on next_obs, the online one on obs
  stats.forward_alive = models::count_alive(flat_obs.ado_alive) + models::count_alive(batch.next_obs.ado_alive.reshape({-1, cfg_.dims.n_other}));
  stats.loss = loss_sum / n;
  stats.q_mean = q_sum / n;
  stats.td_abs_mean = td_sum / n;
  const auto valid = es_is_team(cfg_.variant) ? active.any(1) : active;
  stats.target_mean = t > 0 ? masked_mean(target.value, valid).item<double>() : std::nan("");
  return stats;
}

// The diagnostics of the batch before any step: the policy's, the loss, the huber or end-atom share.
void EsAgent::measure_before_steps(const models::HlObs& obs, const EsBatch& batch, const torch::Tensor& active,
                                   const EsTarget& target, EsStats* stats) {
  torch::NoGradGuard no_grad;
  const auto rows = active.reshape({-1}).nonzero().squeeze(1);
  const auto out = forward_no_grad(false, obs);
  es_policy_diagnostics(out.q.index_select(0, rows), cfg_.n_bins, stats);
  const auto l = es_loss(cfg_.variant, out, batch.actions, active, target, cfg_.huber_delta, support_,
                         cfg_.component_ce_weight, cfg_.d3_loss);
  stats->loss_before = l.loss.item<double>();
  if (cfg_.variant == EsVariant::kEsD3) {
    const auto k = target.dist.size(1);
    const auto ends = target.dist.select(1, 0) + target.dist.select(1, k - 1);
    stats->end_atom_share = masked_mean(ends, active.any(1)).item<double>();
  } else {
    const auto beyond = ((l.prediction - target.value).abs() > cfg_.huber_delta).to(torch::kFloat32);
    stats->huber_share = masked_mean(beyond, l.valid).item<double>();
  }
}

// One gradient step on the minibatch `teams` (int64 [m] team indices), its terms (loss, q, td)
// averaged over the loss units (a team counts once when any member is active, else each active
// member).
// ES+D3's loss that the fused node computes: the paper's cross-entropy alone.
static bool fused_d3_loss(const EsConfig& cfg) {
  return cfg.variant == EsVariant::kEsD3 && cfg.component_ce_weight == 0.0 && cfg.d3_loss == D3Loss::kCrossEntropy;
}

bool es_fused_training(const EsConfig& cfg) {
  return cfg.fused_training && (cfg.variant == EsVariant::kEsD2 || fused_d3_loss(cfg));
}

GradientStepResult EsAgent::minibatch_step(const UpdateData& d, const torch::Tensor& teams, EsStats* stats) {
  // The step's chunks: units (what the loss averages over) first, so each chunk's gradient can
  // weigh by its share while the chunks run concurrently.
  const int64_t m = teams.numel(), n_a = d.n_a;
  const int64_t n_chunks = m == 0 ? 0 : std::min(cfg_.minibatch_chunks, m);
  const bool team_units = es_is_team(cfg_.variant);
  std::vector<ChunkGradient> chunks(static_cast<std::size_t>(n_chunks));
  std::vector<double> chunk_units(static_cast<std::size_t>(n_chunks), 0.0);
  double units = 0.0;
  const int64_t* team = teams.data_ptr<int64_t>();
  for (int64_t c = 0; c < n_chunks; ++c) {
    // Counted on the host.
    for (int64_t r = m * c / n_chunks; r < m * (c + 1) / n_chunks; ++r) {
      int64_t members = 0;
      for (int64_t i = 0; i < n_a; ++i) members += d.active_host[team[r] * n_a + i] ? 1 : 0;
      chunk_units[c] += static_cast<double>(team_units ? (members > 0 ? 1 : 0) : members);
    }
    units += chunk_units[c];
  }
  for (int64_t c = 0; c < n_chunks; ++c)
    chunks[c].weight = n_chunks == 1 ? 1.0 : (units > 0.0 ? chunk_units[c] / units : 0.0);
  const std::vector<torch::Tensor> params = critic_->parameters();
  while (static_cast<int64_t>(chunk_passes_.size()) < n_chunks) chunk_passes_.push_back(std::make_unique<EsChunkPass>());
  const auto run = [&](int64_t c, ChunkGradient& k) {
    // A replica leaves out what has no unit (its loss would be 0/0); one process runs it as a
    // plain backward() would.
    if (chunk_units[c] == 0.0 && (replicas_.active() || n_chunks > 1)) return;
    chunk_gradient(d, teams.slice(0, m * c / n_chunks, m * (c + 1) / n_chunks), n_chunks > 1, params, k,
                   *chunk_passes_[static_cast<std::size_t>(c)]);
  };
  GradientStepOptions o;
  o.zero_unused = true;
  o.max_grad_norm = cfg_.max_grad_norm;
  o.replicas = &replicas_;
  o.mix = ReplicaMix::kUnitMean;
  o.replica_weight = units;
  o.n_terms = 3;
  const GradientStepResult step = gradient_step(*optimizer_, params, chunks, run, o);
  stats->chunk_wait_s += step.chunk_wait_s;
  stats->train_rows += m * n_a;
  for (int64_t r = 0; r < m; ++r) stats->train_alive += d.team_alive[static_cast<std::size_t>(team[r])];
  stats->train_passes += step.passes;
  if (step.stepped) stats->grad_norm = step.grad_norm;
  return step;
}

// One chunk's gradient (weighted by k.weight when `weighted`) and terms (loss, q, td).
void EsAgent::chunk_gradient(const UpdateData& d, const torch::Tensor& teams, bool weighted,
                             const std::vector<torch::Tensor>& params, ChunkGradient& k, EsChunkPass& pass) {
  const bool fused_d3 = fused_d3_loss(cfg_);
  const bool fused_d2 = cfg_.variant == EsVariant::kEsD2;
  if (es_fused_training(cfg_) && teams.numel() > 0) {
    EsChunkRows rows;
    rows.obs = &d.obs;
    rows.t = teams.numel(), rows.n_a = d.n_a;
    rows.teams = teams.data_ptr<int64_t>();
    rows.actions = d.actions.data_ptr<int64_t>();
    rows.active = d.active_host;
    rows.target_value = d.target_value.data_ptr<float>();
    rows.target_dist = fused_d3 ? d.target_dist.data_ptr<float>() : nullptr;
    const EsLossSums s = pass.run(*critic_, rows, weighted ? k.weight : 1.0, cfg_.huber_delta, support_);
    k.grads = pass.grads();
    k.terms = {s.loss * s.inv_valid, s.q * s.inv_valid, s.td * s.inv_valid};
    return;
  }
  const auto rows_c = (teams.unsqueeze(1) * d.n_a + d.aircraft).reshape({-1});
  const EsTarget target_c{d.target.value.index_select(0, teams),
                          d.target.dist.defined() ? d.target.dist.index_select(0, teams) : torch::Tensor()};
  const auto out = critic_->forward(models::index_rows(d.obs, rows_c), /*with_q=*/!fused_d3);
  const double weight = weighted ? k.weight : 1.0;
  if (fused_d2 || fused_d3) {
    // The paper's ES+D2 and ES+D3 losses as one node each (agents/es_fused_loss.hpp; es_loss
    // is their oracle).
    const auto chunk_actions = d.batch.actions.index_select(0, teams);
    const auto chunk_active = d.active.index_select(0, teams);
    const auto f = fused_d2 ? fused_es_d2_loss(out.q, chunk_actions, chunk_active, target_c.value,
                                               cfg_.huber_delta, weight)
                            : fused_es_d3_loss(out.log_probs, chunk_actions, chunk_active, target_c.dist,
                                               target_c.value, support_, weight);
    k.grads = torch::autograd::grad({f.total}, params, /*grad_outputs=*/{}, /*retain_graph=*/false,
                                    /*create_graph=*/false, /*allow_unused=*/true);
    k.terms = {f.loss, f.q, f.td};
    return;
  }
  const auto l = es_loss(cfg_.variant, out, d.batch.actions.index_select(0, teams),
                         d.active.index_select(0, teams), target_c, cfg_.huber_delta, support_,
                         cfg_.component_ce_weight, cfg_.d3_loss);
  k.grads = torch::autograd::grad({weighted ? l.loss * weight : l.loss}, params, /*grad_outputs=*/{},
                                  /*retain_graph=*/false, /*create_graph=*/false, /*allow_unused=*/true);
  torch::NoGradGuard no_grad;
  k.terms = {l.loss.item<double>(), masked_mean(l.prediction, l.valid).item<double>(),
             masked_mean((l.prediction - target_c.value).abs(), l.valid).item<double>()};
}

void EsAgent::save(const std::string& path, CheckpointContent content) const {
  torch::serialize::OutputArchive root;
  write_sub_archive(root, "critic", *critic_);
  if (content == CheckpointContent::kFull) write_sub_archive(root, "target", *target_);
  root.write("variant", torch::tensor(static_cast<int64_t>(cfg_.variant)));
  write_agent_state(root, *normalizer_, *optimizer_, update_count_, generator_, content);
  save_archive_atomic(root, path);
}

void EsAgent::set_replicas(const Replicas& replicas) {
  replicas_ = replicas;
  normalizer_->set_moments_gather(replicas.gather);
}

void EsAgent::load(const std::string& path) {
  torch::serialize::InputArchive root;
  root.load_from(path);
  load_archive(root);
}

void EsAgent::load_bytes(const std::string& bytes) {
  torch::serialize::InputArchive root;
  root.load_from(bytes.data(), bytes.size());
  load_archive(root);
}

void EsAgent::load_archive(torch::serialize::InputArchive& root) {
  const auto variant = static_cast<EsVariant>(read_int(root, "variant"));
  TORCH_CHECK(variant == cfg_.variant, "EsAgent::load: the file holds variant ", es_variant_name(variant),
              ", this agent is ", es_variant_name(cfg_.variant));
  read_sub_archive(root, "critic", *critic_);
  torch::serialize::InputArchive target;
  const bool has_target = root.try_read("target", target);
  if (has_target) target_->load(target);
  loaded_content_ = read_agent_state(root, *normalizer_, *optimizer_, &update_count_, generator_);
  if (!has_target) sync_target();  // a policy-only file: acting never reads the target
}

}  // namespace f16race::agents
