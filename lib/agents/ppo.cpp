#include "agents/ppo.hpp"

#include <omp.h>

#include <algorithm>
#include <array>
#include <cmath>
#include <exception>
#include <vector>

#include "agents/checkpoint.hpp"
#include "agents/ppo_fused_loss.hpp"

namespace f16race::agents {

PpoLossTerms ppo_loss(const torch::Tensor& new_log_prob, const torch::Tensor& old_log_prob,
                      const torch::Tensor& advantages, const torch::Tensor& new_value, const torch::Tensor& old_value,
                      const torch::Tensor& returns, const torch::Tensor& entropy, const PpoConfig& cfg) {
  models::check_tensor(new_log_prob, "new_log_prob", {-1}, torch::kFloat32);
  const int64_t m = new_log_prob.size(0);
  for (const auto& [t, name] : {std::pair{&old_log_prob, "old_log_prob"}, {&advantages, "advantages"},
                                {&new_value, "new_value"}, {&old_value, "old_value"}, {&returns, "returns"},
                                {&entropy, "entropy"}}) {
    models::check_tensor(*t, name, {m}, torch::kFloat32);
  }
  PpoLossTerms out;
  const auto log_ratio = new_log_prob - old_log_prob;
  const auto ratio = log_ratio.exp();
  {
    torch::NoGradGuard no_grad;
    out.approx_kl = ((ratio - 1.0) - log_ratio).mean();
    out.clip_fraction = ((ratio - 1.0).abs() > cfg.clip_coef).to(torch::kFloat32).mean();
  }
  auto adv = advantages;
  if (cfg.normalize_advantages && m > 1) adv = (adv - adv.mean()) / (adv.std() + 1e-8);
  const auto pg1 = -adv * ratio;
  const auto pg2 = -adv * torch::clamp(ratio, 1.0 - cfg.clip_coef, 1.0 + cfg.clip_coef);
  out.policy_loss = torch::max(pg1, pg2).mean();
  const auto v_unclipped = (new_value - returns).pow(2);
  if (cfg.clip_value_loss) {
    const auto v_clipped = old_value + torch::clamp(new_value - old_value, -cfg.clip_coef, cfg.clip_coef);
    out.value_loss = 0.5 * torch::max(v_unclipped, (v_clipped - returns).pow(2)).mean();
  } else {
    out.value_loss = 0.5 * v_unclipped.mean();
  }
  out.entropy = entropy.mean();
  out.total = out.policy_loss - cfg.ent_coef * out.entropy + cfg.vf_coef * out.value_loss;
  return out;
}

PpoAgent::PpoAgent(const PpoConfig& cfg) : cfg_(cfg), generator_(models::make_generator(cfg.seed)) {
  TORCH_CHECK(cfg.n_minibatches > 0 && cfg.n_epochs > 0 && cfg.n_steps > 0,
              "PpoConfig: n_steps, n_minibatches, n_epochs must be > 0");
  TORCH_CHECK(!cfg.anneal_lr || cfg.total_updates > 0, "PpoConfig: anneal_lr needs total_updates > 0");
  net_ = models::LlActorCritic(cfg.net);
  if (cfg.eigen_inference) eigen_.follow(net_->parameters(), [net = net_] { return net->eigen_weights(); });
  normalizer_ = models::ObsNormalizer(cfg.net.dims, cfg.obs_clip);
  optimizer_ = std::make_unique<torch::optim::Adam>(net_->parameters(),
                                                    torch::optim::AdamOptions(cfg.learning_rate).eps(cfg.adam_eps));
}

models::LlObs PpoAgent::normalize(const models::LlObs& raw, bool update_stats) {
  if (!cfg_.normalize_obs) {
    models::check_obs(raw, cfg_.net.dims);
    return raw;
  }
  return normalizer_->normalize(raw, update_stats);
}

std::pair<torch::Tensor, torch::Tensor> PpoAgent::infer(const models::LlObs& obs) {
  if (!cfg_.eigen_inference) {
    const auto out = net_(obs);
    return {out.mean, out.value};
  }
  const int64_t b = models::check_obs(obs, cfg_.net.dims);
  auto mean = torch::empty({b, cfg_.net.action_dim});
  auto value = torch::empty({b});
  infer_into(obs, mean, value, nullptr);
  return {mean, value};
}

void PpoAgent::infer_into(const models::LlObs& obs, torch::Tensor& mean, torch::Tensor& value,
                          const models::GaussianDraw* draw) {
  const auto ego = obs.ego.contiguous(), goal = obs.goal.contiguous(), ado = obs.ado.contiguous(),
             alive = obs.ado_alive.contiguous(), task = obs.task.contiguous();
  eigen_.current().forward(mean.size(0), ego.data_ptr<float>(), goal.data_ptr<float>(), ado.data_ptr<float>(),
                 alive.data_ptr<bool>(), task.data_ptr<float>(), mean.data_ptr<float>(), value.data_ptr<float>(), draw);
}

PpoAction PpoAgent::act(const models::LlObs& raw, at::Generator& generator, bool update_stats) {
  return act(raw, torch::Tensor(), generator, update_stats);
}

void PpoAgent::infer_raw_into(const models::LlObs& raw, const torch::Tensor& rows, const models::LlObs& out,
                              torch::Tensor& mean, torch::Tensor& value, const models::GaussianDraw* draw) {
  const models::LlObs fields{raw.ego.contiguous(), raw.goal.contiguous(), raw.ado.contiguous(),
                             raw.ado_alive.contiguous(), raw.task.contiguous()};
  const auto index = rows.defined() ? rows.contiguous() : rows;
  const models::LlRawRows r = normalizer_->raw_rows(fields, index, out, &norm_terms_);
  eigen_.current().forward(mean.size(0), r, mean.data_ptr<float>(), value.data_ptr<float>(), draw);
}

PpoAction PpoAgent::act(const models::LlObs& raw, const torch::Tensor& rows, at::Generator& generator,
                        bool update_stats) {
  torch::NoGradGuard no_grad;
  PpoAction a;
  // Eigen inference on normalised observations: the statistics absorb the batch here, and the
  // forward's blocks normalise their own rows on the threads (the serial normalisation and its
  // tensors were ~3 % of a 32-env run); a.obs receives the same bits ObsNormalizer gives.
  const bool fused = cfg_.eigen_inference && cfg_.normalize_obs;
  if (fused) {
    const auto& d = cfg_.net.dims;
    const int64_t n = models::check_obs(raw, d);
    int64_t b = n;
    if (rows.defined()) {
      models::check_tensor(rows, "rows", {-1}, torch::kInt64);
      b = rows.numel();
      const auto idx = rows.contiguous();
      const int64_t* p = idx.data_ptr<int64_t>();
      for (int64_t i = 0; i < b; ++i)
        TORCH_CHECK(p[i] >= 0 && p[i] < n, "PpoAgent::act: row ", p[i], " outside the ", n, " rows");
    }
    if (update_stats) normalizer_->absorb(raw, rows);
    a.obs = models::LlObs{torch::empty({b, d.d_ego}), torch::empty({b, d.d_goal}),
                          torch::empty({b, d.n_other, d.d_ado}), torch::empty({b, d.n_other}, torch::kBool),
                          torch::empty({b, d.d_task})};
  } else if (!rows.defined()) {
    a.obs = normalize(raw, update_stats);
  } else if (cfg_.normalize_obs) {
    a.obs = normalizer_->normalize(raw, rows, update_stats);
  } else {
    a.obs = normalize(models::index_rows(raw, rows), false);
  }
  if (cfg_.eigen_inference) {
    // The draw in the forward's blocks, on the threads (the torch ops below were ~4 % of a 32-env
    // run, on one thread); the same noise from the same generator, the same bits.
    const int64_t b = models::check_obs(a.obs, cfg_.net.dims), n_act = cfg_.net.action_dim;
    const auto noise = torch::randn({b, n_act}, generator, torch::kFloat32);
    const auto log_std = net_->log_std().contiguous();
    const auto std_dev = log_std.exp(), inv_std = (-log_std).exp();
    a.mean = torch::empty({b, n_act});
    a.value = torch::empty({b});
    a.action = torch::empty({b, n_act});
    a.log_prob = torch::empty({b});
    models::GaussianDraw draw;
    draw.noise = noise.data_ptr<float>();
    draw.std = std_dev.data_ptr<float>();
    draw.inv_std = inv_std.data_ptr<float>();
    draw.log_std = log_std.data_ptr<float>();
    draw.action = a.action.data_ptr<float>();
    draw.log_prob = a.log_prob.data_ptr<float>();
    if (fused)
      infer_raw_into(raw, rows, a.obs, a.mean, a.value, &draw);
    else
      infer_into(a.obs, a.mean, a.value, &draw);
    return a;
  }
  const auto [mean, value] = infer(a.obs);
  const auto log_std = net_->log_std().expand_as(mean);
  const auto noise = torch::randn(mean.sizes(), generator, torch::kFloat32);
  a.action = mean + noise * log_std.exp();
  a.log_prob = models::gaussian_log_prob(mean, log_std, a.action);
  a.value = value;
  a.mean = mean;
  return a;
}

torch::Tensor PpoAgent::value(const models::LlObs& raw) {
  torch::NoGradGuard no_grad;
  return infer(normalize(raw, false)).second;
}

double PpoAgent::learning_rate_for_update(int64_t update_index) const {
  if (!cfg_.anneal_lr) return cfg_.learning_rate;
  // CleanRL: frac = 1 - (iteration - 1) / num_iterations, so update 0 uses the full rate and the
  // last planned update 1/total_updates of it.
  const double frac = 1.0 - static_cast<double>(update_index) / static_cast<double>(cfg_.total_updates);
  return cfg_.learning_rate * std::max(frac, 0.0);
}

// What every gradient step of one update reads: the valid samples (rows of the buffer) and
// their rollout values.
struct PpoAgent::UpdateData {
  models::LlObs buffer_obs;  // every row of the buffer; chunks gather theirs from it
  torch::Tensor rows;        // int64 [batch]: the valid rows
  torch::Tensor actions, old_log_probs, old_values, advantages, returns;  // [batch, ...]
  std::vector<int64_t> valid_alive;  // other aircraft alive per valid sample (bench train)
  PpoConfig chunk_cfg;  // the config without advantage normalisation (done per minibatch)
};

namespace {

// Replicas: each union minibatch's row count and advantage moments (count, sum, sum of squares
// per minibatch), for the whole epoch in one reduction, so every replica normalises as one
// process would over the union (unbiased std, as CleanRL).
std::vector<double> union_moments(const torch::Tensor& advantages, const std::vector<torch::Tensor>& minibatches,
                                  const Replicas& replicas) {
  std::vector<double> moments(3 * minibatches.size(), 0.0);
  const float* a = advantages.data_ptr<float>();
  for (std::size_t k = 0; k < minibatches.size(); ++k) {
    const int64_t* idx = minibatches[k].data_ptr<int64_t>();
    moments[3 * k] = static_cast<double>(minibatches[k].numel());
    for (int64_t i = 0; i < minibatches[k].numel(); ++i) {
      const double x = a[idx[i]];
      moments[3 * k + 1] += x;
      moments[3 * k + 2] += x * x;
    }
  }
  replicas.sum_doubles(moments.data(), static_cast<int64_t>(moments.size()));
  return moments;
}

}  // namespace

PpoStats PpoAgent::update(const RolloutBuffer& buffer) {
  TORCH_CHECK(buffer.finished(), "PpoAgent::update: call RolloutBuffer::finish first");
  // Replicas: the rollout's observation statistics, held back during it, absorb every rank's now.
  if (cfg_.normalize_obs) normalizer_->sync_replicas();
  PpoStats stats;
  stats.learning_rate = learning_rate_for_update(update_count_);
  for (auto& group : optimizer_->param_groups()) {
    static_cast<torch::optim::AdamOptions&>(group.options()).lr(stats.learning_rate);
  }
  const UpdateData d = update_data(buffer);
  const int64_t batch = d.rows.numel();
  int64_t n_steps = 0;
  for (int64_t epoch = 0; epoch < cfg_.n_epochs; ++epoch) {
    const auto perm = torch::randperm(batch, generator_, torch::kInt64);
    const std::vector<torch::Tensor> minibatches = perm.tensor_split(cfg_.n_minibatches);
    const std::vector<double> moments =
        replicas_.active() ? union_moments(d.advantages, minibatches, replicas_) : std::vector<double>();
    for (std::size_t k = 0; k < minibatches.size(); ++k)
      if (minibatch_step(d, minibatches[k], replicas_.active() ? &moments[3 * k] : nullptr, &stats)) ++n_steps;
  }
  stats.grad_steps = n_steps;
  const double n = static_cast<double>(std::max<int64_t>(n_steps, 1));
  stats.policy_loss /= n;
  stats.value_loss /= n;
  stats.entropy /= n;
  stats.approx_kl /= n;
  stats.clip_fraction /= n;
  const double var_returns = d.returns.var(/*unbiased=*/false).item<double>();
  stats.explained_variance =
      var_returns > 0.0 ? 1.0 - (d.returns - d.old_values).var(/*unbiased=*/false).item<double>() / var_returns : 0.0;
  ++update_count_;
  stats.update_index = update_count_;
  return stats;
}

PpoAgent::UpdateData PpoAgent::update_data(const RolloutBuffer& buffer) const {
  // Only valid samples (aircraft that acted) enter the update. A replica may hold none this time
  // and still takes part in every step (its share is then 0).
  const auto rows = buffer.valid.flatten().nonzero().squeeze(1);
  TORCH_CHECK(rows.numel() > 0 || replicas_.active(), "PpoAgent::update: the buffer holds no valid sample");
  // Observations stay in the buffer: each chunk gathers its rows from it (rows[chunk's]), where a
  // compacted copy of the valid rows cost a serial copy of the whole buffer per update.
  const models::LlObs flat = models::flatten2(buffer.obs);
  UpdateData d{models::LlObs{flat.ego.contiguous(), flat.goal.contiguous(), flat.ado.contiguous(),
                             flat.ado_alive.contiguous(), flat.task.contiguous()},
               rows,
               buffer.actions.flatten(0, 1).index_select(0, rows),
               buffer.log_probs.flatten().index_select(0, rows),
               buffer.values.flatten().index_select(0, rows),
               buffer.advantages.flatten().index_select(0, rows),
               buffer.returns.flatten().index_select(0, rows),
               std::vector<int64_t>(static_cast<std::size_t>(rows.numel())),
               cfg_};
  // Advantages are normalised over the whole minibatch (CleanRL), before it is cut into chunks.
  d.chunk_cfg.normalize_advantages = false;
  const std::vector<int64_t> per_row = models::alive_per_row(d.buffer_obs.ado_alive);
  const int64_t* r = rows.data_ptr<int64_t>();
  for (std::size_t i = 0; i < d.valid_alive.size(); ++i) d.valid_alive[i] = per_row[static_cast<std::size_t>(r[i])];
  return d;
}

// One gradient step on minibatch `mb` (positions in d.rows); moments: the union's (count, sum,
// sum of squares) of its advantages with replicas, else null. False: no step (no rows).
bool PpoAgent::minibatch_step(const UpdateData& d, const torch::Tensor& mb, const double* moments, PpoStats* stats) {
  const int64_t m = mb.numel();
  auto adv = d.advantages.index_select(0, mb);
  double share = 1.0;  // this process's share of the step's rows (replicas: of the union's)
  if (moments) {
    const double total = moments[0];
    if (total == 0.0) return false;  // the same on every replica
    share = static_cast<double>(m) / total;
    if (cfg_.normalize_advantages && total > 1.0 && m > 0) {
      const double mean = moments[1] / total;
      const double var = std::max(0.0, (moments[2] - total * mean * mean) / (total - 1.0));
      adv = (adv - static_cast<float>(mean)) / static_cast<float>(std::sqrt(var) + 1e-8);
    }
  } else {
    if (m == 0) return false;
    if (cfg_.normalize_advantages && m > 1) adv = (adv - adv.mean()) / (adv.std() + 1e-8);
  }
  adv = adv.contiguous();
  const int64_t n_chunks =
      m == 0 ? 0 : cfg_.max_chunk_rows > 0 ? (m + cfg_.max_chunk_rows - 1) / cfg_.max_chunk_rows : 1;
  std::vector<ChunkGradient> chunks(static_cast<std::size_t>(n_chunks));
  for (int64_t c = 0; c < n_chunks; ++c)  // contiguous slices of the shuffled minibatch
    chunks[c].weight = static_cast<double>(m * (c + 1) / n_chunks - m * c / n_chunks) / static_cast<double>(m);
  const std::vector<torch::Tensor> params = net_->parameters();
  while (static_cast<int64_t>(chunk_passes_.size()) < n_chunks) chunk_passes_.push_back(std::make_unique<PpoChunkPass>());
  const auto run_fused = [&](int64_t c, ChunkGradient& r) {
    const int64_t lo = m * c / n_chunks, hi = m * (c + 1) / n_chunks;
    PpoChunkRows rows;
    rows.obs = &d.buffer_obs;
    rows.m = hi - lo;
    rows.positions = mb.data_ptr<int64_t>() + lo;
    rows.valid_rows = d.rows.data_ptr<int64_t>();
    rows.actions = d.actions.data_ptr<float>();
    rows.old_log_probs = d.old_log_probs.data_ptr<float>();
    rows.old_values = d.old_values.data_ptr<float>();
    rows.returns = d.returns.data_ptr<float>();
    rows.advantages = adv.data_ptr<float>() + lo;
    const PpoLossCoefs coefs{cfg_.clip_coef, cfg_.vf_coef, cfg_.ent_coef, cfg_.clip_value_loss};
    PpoChunkPass& pass = *chunk_passes_[static_cast<std::size_t>(c)];
    const std::array<double, 5> t = pass.run(*net_, rows, n_chunks == 1 ? 1.0 : r.weight, coefs);
    r.grads = pass.grads();
    r.terms = {t[0], t[1], t[2], t[3], t[4]};
  };
  const auto run_autograd = [&](int64_t c, ChunkGradient& r) {
    const int64_t lo = m * c / n_chunks, hi = m * (c + 1) / n_chunks;
    const auto rows_c = mb.slice(0, lo, hi);
    const auto out = net_(models::index_rows(d.buffer_obs, d.rows.index_select(0, rows_c)));
    // The loss terms as one node (agents/ppo_fused_loss.hpp; ppo_loss is its oracle in the tests),
    // each chunk's mean weighed by its share.
    const auto loss = fused_ppo_loss(out.mean, out.log_std, out.value, d.actions.index_select(0, rows_c),
                                     d.old_log_probs.index_select(0, rows_c), adv.slice(0, lo, hi),
                                     d.old_values.index_select(0, rows_c), d.returns.index_select(0, rows_c),
                                     d.chunk_cfg, n_chunks == 1 ? 1.0 : r.weight);
    r.grads = torch::autograd::grad({loss.total}, params, /*grad_outputs=*/{}, /*retain_graph=*/false,
                                    /*create_graph=*/false, /*allow_unused=*/true);
    r.terms = {loss.policy_loss, loss.value_loss, loss.entropy, loss.approx_kl, loss.clip_fraction};
  };
  GradientStepOptions o;
  o.max_grad_norm = cfg_.max_grad_norm;
  o.replicas = &replicas_;
  o.mix = ReplicaMix::kShareWeighted;
  o.replica_weight = share;
  const GradientStepResult step = cfg_.fused_training ? gradient_step(*optimizer_, params, chunks, run_fused, o)
                                                      : gradient_step(*optimizer_, params, chunks, run_autograd, o);
  stats->chunk_wait_s += step.chunk_wait_s;
  stats->policy_loss += step.terms[0];
  stats->value_loss += step.terms[1];
  stats->entropy += step.terms[2];
  stats->approx_kl += step.terms[3];
  stats->clip_fraction += step.terms[4];
  stats->train_passes += n_chunks;
  stats->train_rows += m;
  const int64_t* picked = mb.data_ptr<int64_t>();
  for (int64_t i = 0; i < m; ++i) stats->train_alive += d.valid_alive[static_cast<std::size_t>(picked[i])];
  return true;
}

void PpoAgent::set_replicas(const Replicas& replicas) {
  replicas_ = replicas;
  normalizer_->set_moments_gather(replicas.gather);
}

void PpoAgent::save(const std::string& path, CheckpointContent content) const {
  torch::serialize::OutputArchive root;
  write_sub_archive(root, "net", *net_);
  write_agent_state(root, *normalizer_, *optimizer_, update_count_, generator_, content);
  save_archive_atomic(root, path);
}

void PpoAgent::load(const std::string& path) {
  torch::serialize::InputArchive root;
  root.load_from(path);
  load_archive(root);
}

void PpoAgent::load_bytes(const std::string& bytes) {
  torch::serialize::InputArchive root;
  root.load_from(bytes.data(), bytes.size());
  load_archive(root);
}

void PpoAgent::load_archive(torch::serialize::InputArchive& root) {
  read_sub_archive(root, "net", *net_);
  loaded_content_ = read_agent_state(root, *normalizer_, *optimizer_, &update_count_, generator_);
}

}  // namespace f16race::agents
