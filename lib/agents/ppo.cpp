#include "agents/ppo.hpp"

#include <omp.h>

#include <algorithm>
#include <array>
#include <cmath>
#include <exception>
#include <vector>

#include "agents/checkpoint.hpp"
#include "agents/concurrent_chunks.hpp"
#include "agents/optimizer_step.hpp"
#include "agents/ppo_fused_loss.hpp"

namespace f16race::agents {
namespace {

// One chunk's share of a minibatch step: its gradients (already weighted by its share of rows)
// and its loss terms (policy, value, entropy, approx_kl, clip_fraction).
struct ChunkResult {
  double weight = 0.0;
  std::vector<torch::Tensor> grads;
  std::array<double, 5> terms{};
};

}  // namespace

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

PpoStats PpoAgent::update(const RolloutBuffer& buffer) {
  TORCH_CHECK(buffer.finished(), "PpoAgent::update: call RolloutBuffer::finish first");
  // Replicas: the rollout's observation statistics, held back during it, absorb every rank's now.
  if (cfg_.normalize_obs) normalizer_->sync_replicas();
  PpoStats stats;
  stats.learning_rate = learning_rate_for_update(update_count_);
  for (auto& group : optimizer_->param_groups()) {
    static_cast<torch::optim::AdamOptions&>(group.options()).lr(stats.learning_rate);
  }
  // Only valid samples (aircraft that acted) enter the update. A replica may hold none this time
  // and still takes part in every step (its share is then 0).
  const auto rows = buffer.valid.flatten().nonzero().squeeze(1);
  TORCH_CHECK(rows.numel() > 0 || replicas_.active(), "PpoAgent::update: the buffer holds no valid sample");
  // Observations stay in the buffer: each chunk gathers its rows from it (rows[chunk's]), where a
  // compacted copy of the valid rows cost a serial copy of the whole buffer per update.
  const auto buffer_obs = models::flatten2(buffer.obs);
  const auto actions = buffer.actions.flatten(0, 1).index_select(0, rows);
  const auto old_log_probs = buffer.log_probs.flatten().index_select(0, rows);
  const auto old_values = buffer.values.flatten().index_select(0, rows);
  const auto advantages = buffer.advantages.flatten().index_select(0, rows);
  const auto returns = buffer.returns.flatten().index_select(0, rows);
  const int64_t batch = rows.numel();

  const std::vector<torch::Tensor> params = net_->parameters();
  // Advantages are normalised over the whole minibatch (CleanRL), before it is cut into chunks.
  PpoConfig chunk_cfg = cfg_;
  chunk_cfg.normalize_advantages = false;
  // Other aircraft alive per valid sample (position in `rows`): the passes' alive share, which
  // bench train's floor prices them at.
  std::vector<int64_t> valid_alive(static_cast<std::size_t>(batch));
  {
    const std::vector<int64_t> per_row = models::alive_per_row(buffer_obs.ado_alive);
    const int64_t* r = rows.data_ptr<int64_t>();
    for (int64_t i = 0; i < batch; ++i) valid_alive[static_cast<std::size_t>(i)] = per_row[static_cast<std::size_t>(r[i])];
  }
  int64_t n_steps = 0;
  for (int64_t epoch = 0; epoch < cfg_.n_epochs; ++epoch) {
    const auto perm = torch::randperm(batch, generator_, torch::kInt64);
    const std::vector<torch::Tensor> minibatches = perm.tensor_split(cfg_.n_minibatches);
    // Replicas: each union minibatch's row count and advantage moments, for the whole epoch in one
    // reduction, so every replica normalises as one process would over the union (unbiased std,
    // as CleanRL).
    std::vector<double> moments;
    if (replicas_.active()) {
      moments.assign(3 * minibatches.size(), 0.0);
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
      replicas_.sum_doubles(moments.data(), static_cast<int64_t>(moments.size()));
    }
    for (std::size_t k = 0; k < minibatches.size(); ++k) {
      const torch::Tensor& mb = minibatches[k];
      const int64_t m = mb.numel();
      auto adv = advantages.index_select(0, mb);
      double share = 1.0;  // this process's share of the step's rows (replicas: of the union's)
      if (replicas_.active()) {
        const double total = moments[3 * k];
        if (total == 0.0) continue;  // the same on every replica
        share = static_cast<double>(m) / total;
        if (cfg_.normalize_advantages && total > 1.0 && m > 0) {
          const double mean = moments[3 * k + 1] / total;
          const double var = std::max(0.0, (moments[3 * k + 2] - total * mean * mean) / (total - 1.0));
          adv = (adv - static_cast<float>(mean)) / static_cast<float>(std::sqrt(var) + 1e-8);
        }
      } else {
        if (m == 0) continue;
        if (cfg_.normalize_advantages && m > 1) adv = (adv - adv.mean()) / (adv.std() + 1e-8);
      }
      const int64_t n_chunks =
          m == 0 ? 0 : cfg_.max_chunk_rows > 0 ? (m + cfg_.max_chunk_rows - 1) / cfg_.max_chunk_rows : 1;
      // Each chunk's gradient on its own (autograd::grad, nothing accumulated in place), on the
      // OpenMP threads when there are several chunks; then summed in chunk order, which is what
      // serial backward() calls accumulate. So the step is the same bits at any thread count.
      std::vector<ChunkResult> chunks(static_cast<std::size_t>(n_chunks));
      auto run_chunk = [&](int64_t c) {
        // Contiguous slices of the shuffled minibatch; each chunk's mean weighs by its share.
        const int64_t lo = m * c / n_chunks, hi = m * (c + 1) / n_chunks;
        const auto rows_c = mb.slice(0, lo, hi);
        const auto out = net_(models::index_rows(buffer_obs, rows.index_select(0, rows_c)));
        ChunkResult& r = chunks[static_cast<std::size_t>(c)];
        r.weight = static_cast<double>(hi - lo) / static_cast<double>(m);
        // The loss terms as one node (agents/ppo_fused_loss.hpp; ppo_loss is its oracle in the tests).
        const auto loss = fused_ppo_loss(out.mean, out.log_std, out.value, actions.index_select(0, rows_c),
                                         old_log_probs.index_select(0, rows_c), adv.slice(0, lo, hi),
                                         old_values.index_select(0, rows_c), returns.index_select(0, rows_c),
                                         chunk_cfg, n_chunks == 1 ? 1.0 : r.weight);
        r.grads = torch::autograd::grad({loss.total}, params, /*grad_outputs=*/{}, /*retain_graph=*/false,
                                        /*create_graph=*/false, /*allow_unused=*/true);
        r.terms = {loss.policy_loss, loss.value_loss, loss.entropy, loss.approx_kl, loss.clip_fraction};
      };
      stats.chunk_wait_s += run_chunks(n_chunks, run_chunk);
      std::array<double, 5> terms{};
      for (const auto& r : chunks)
        for (std::size_t q = 0; q < terms.size(); ++q) terms[q] += r.weight * r.terms[q];
      std::vector<const std::vector<torch::Tensor>*> chunk_grads;
      for (const auto& r : chunks) chunk_grads.push_back(&r.grads);
      sum_chunk_gradients(params, chunk_grads, /*zero_unused=*/false);
      if (replicas_.active()) {
        // The union's gradient: each replica's weighted by its share of the union's rows.
        std::vector<double> extra(terms.size());
        for (std::size_t q = 0; q < terms.size(); ++q) extra[q] = terms[q] * share;
        sum_weighted_gradients(params, share, extra, replicas_);
        std::copy(extra.begin(), extra.end(), terms.begin());
      }
      stats.policy_loss += terms[0];
      stats.value_loss += terms[1];
      stats.entropy += terms[2];
      stats.approx_kl += terms[3];
      stats.clip_fraction += terms[4];
      stats.train_passes += n_chunks;
      clip_and_adam_step(*optimizer_, cfg_.max_grad_norm);
      stats.train_rows += m;
      const int64_t* picked = mb.data_ptr<int64_t>();
      for (int64_t i = 0; i < m; ++i) stats.train_alive += valid_alive[static_cast<std::size_t>(picked[i])];
      ++n_steps;
    }
  }
  stats.grad_steps = n_steps;
  const double n = static_cast<double>(std::max<int64_t>(n_steps, 1));
  stats.policy_loss /= n;
  stats.value_loss /= n;
  stats.entropy /= n;
  stats.approx_kl /= n;
  stats.clip_fraction /= n;
  const double var_returns = returns.var(/*unbiased=*/false).item<double>();
  stats.explained_variance =
      var_returns > 0.0 ? 1.0 - (returns - old_values).var(/*unbiased=*/false).item<double>() / var_returns : 0.0;
  ++update_count_;
  stats.update_index = update_count_;
  return stats;
}

void PpoAgent::set_replicas(const Replicas& replicas) {
  replicas_ = replicas;
  normalizer_->set_moments_gather(replicas.gather);
}

void PpoAgent::save(const std::string& path) const {
  torch::serialize::OutputArchive root;
  write_sub_archive(root, "net", *net_);
  write_agent_state(root, *normalizer_, *optimizer_, update_count_, generator_);
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
  read_agent_state(root, *normalizer_, *optimizer_, &update_count_, generator_);
}

}  // namespace f16race::agents
