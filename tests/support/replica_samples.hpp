#pragma once
// Samples for tests of data-parallel replicas (agents/replicas.hpp): a PPO rollout and an ES batch
// whose rows a test splits between ranks, the update of an agent on a slice of them, and
// comparisons of networks. Used by tests/agents/test_replicas.cpp (threads as ranks) and
// tests/dist/replicas_over_gloo.cpp (processes over Gloo).
#include <torch/torch.h>

#include <algorithm>
#include <vector>

#include "agents/expected_sarsa.hpp"
#include "agents/ppo.hpp"
#include "agents/rollout_buffer.hpp"

namespace f16race::test_support {

using agents::EsBatch;
using agents::PpoAgent;
using agents::PpoStats;
using agents::RolloutBuffer;

inline double max_abs_diff(torch::nn::Module& a, torch::nn::Module& b) {
  const auto pb = b.named_parameters();
  double d = 0.0;
  for (const auto& item : a.named_parameters()) d = std::max(d, (item.value() - pb[item.key()]).abs().max().item<double>());
  return d;
}

inline bool same_bits(torch::nn::Module& a, torch::nn::Module& b) {
  const auto pb = b.named_parameters();
  for (const auto& item : a.named_parameters())
    if (!item.value().equal(pb[item.key()])) return false;
  return true;
}

// One rollout of 10 aircraft over 6 steps: rows [0, 6) are rank 0's, [6, 10) rank 1's; some
// samples invalid (dead aircraft), so the ranks hold unequal shares.
struct PpoSamples {
  std::vector<models::LlObs> obs;
  std::vector<torch::Tensor> action, logp, value, reward, valid;
};

inline PpoSamples ppo_samples(const models::ObsDims& dims) {
  auto gen = models::make_generator(11);
  PpoSamples s;
  for (int t = 0; t < 6; ++t) {
    s.obs.push_back(models::LlObs{torch::randn({10, dims.d_ego}, gen, torch::kFloat32) * 3.0 + 1.0,
                                  torch::randn({10, 3}, gen, torch::kFloat32),
                                  torch::randn({10, dims.n_other, dims.d_ado}, gen, torch::kFloat32),
                                  torch::rand({10, dims.n_other}, gen) > 0.3,
                                  torch::randn({10, dims.d_task}, gen, torch::kFloat32)});
    s.action.push_back(torch::randn({10, 3}, gen, torch::kFloat32));
    s.logp.push_back(torch::randn({10}, gen, torch::kFloat32) - 2.0);
    s.value.push_back(torch::randn({10}, gen, torch::kFloat32));
    s.reward.push_back(torch::randn({10}, gen, torch::kFloat32));
    s.valid.push_back(torch::rand({10}, gen) > 0.25);
  }
  return s;
}

inline models::LlObs rows_of(const models::LlObs& o, int64_t lo, int64_t hi) {
  return {o.ego.slice(0, lo, hi), o.goal.slice(0, lo, hi), o.ado.slice(0, lo, hi), o.ado_alive.slice(0, lo, hi),
          o.task.slice(0, lo, hi)};
}

// The agent's own normaliser (statistics updated) fills the buffer, as in a rollout.
inline PpoStats ppo_update_on(PpoAgent& agent, const PpoSamples& s, int64_t lo, int64_t hi) {
  const int64_t n = hi - lo;
  RolloutBuffer buffer(static_cast<int64_t>(s.obs.size()), n, agent.config().net.dims);
  auto gen = models::make_generator(3);
  for (std::size_t t = 0; t < s.obs.size(); ++t) {
    const auto norm = agent.normalize(rows_of(s.obs[t], lo, hi), /*update_stats=*/true);
    buffer.add(norm, s.action[t].slice(0, lo, hi), s.logp[t].slice(0, lo, hi), s.value[t].slice(0, lo, hi),
               s.reward[t].slice(0, lo, hi), torch::zeros({n}, torch::kBool), torch::zeros({n}, torch::kBool),
               torch::Tensor(), s.valid[t].slice(0, lo, hi));
  }
  buffer.finish(torch::zeros({n}), agent.config().gamma, agent.config().gae_lambda);
  return agent.update(buffer);
}

// T teams of 3 aircraft; teams [0, 5) are rank 0's, [5, 8) rank 1's.
inline EsBatch es_batch(const models::ObsDims& dims, int64_t lo, int64_t hi) {
  auto gen = models::make_generator(21);
  const int64_t t = 8, n = 3;
  auto obs = [&] {
    return models::HlObs{torch::randn({t, n, dims.d_ego}, gen, torch::kFloat32) * 2.0 + 0.5,
                         torch::randn({t, n, 3}, gen, torch::kFloat32),
                         torch::randn({t, n, dims.n_other, dims.d_ado}, gen, torch::kFloat32),
                         torch::rand({t, n, dims.n_other}, gen) > 0.2,
                         torch::randn({t, n, dims.d_task}, gen, torch::kFloat32)};
  };
  EsBatch b;
  b.obs = obs();
  b.next_obs = obs();
  b.actions = torch::randint(0, 7, {t, n, 3}, gen, torch::kInt64);
  b.reward = torch::randn({t, n}, gen, torch::kFloat32);
  b.done = torch::rand({t}, gen) > 0.6;
  b.active = torch::rand({t, n}, gen) > 0.2;
  b.next_active = torch::rand({t, n}, gen) > 0.2;
  auto cut = [&](const models::HlObs& o) {
    return models::HlObs{o.ego.slice(0, lo, hi), o.prev_action.slice(0, lo, hi), o.ado.slice(0, lo, hi),
                         o.ado_alive.slice(0, lo, hi), o.task.slice(0, lo, hi)};
  };
  return EsBatch{cut(b.obs), b.actions.slice(0, lo, hi), b.reward.slice(0, lo, hi), cut(b.next_obs),
                 b.done.slice(0, lo, hi), b.active.slice(0, lo, hi), b.next_active.slice(0, lo, hi), 0.1};
}

// Small networks and full-batch steps (one minibatch per epoch: a replica's minibatch is all its
// rows, so the union of the ranks' is one process's), with a learning rate large enough that a
// wrong gradient shows in the weights.
inline agents::PpoConfig replica_ppo_config(const models::ObsDims& dims) {
  agents::PpoConfig cfg;
  cfg.net.dims = dims;
  cfg.net.hidden = {16, 16};
  cfg.net.d_model = 16;
  cfg.net.n_heads = 2;
  cfg.n_steps = 6;
  cfg.n_minibatches = 1;
  cfg.n_epochs = 3;
  cfg.total_updates = 4;
  cfg.learning_rate = 1e-2;
  return cfg;
}

inline agents::EsConfig replica_es_config(agents::EsVariant v, const models::ObsDims& dims) {
  agents::EsConfig cfg;
  cfg.variant = v;
  cfg.dims = dims;
  cfg.d_model = 16;
  cfg.n_heads = 2;
  cfg.hidden = {16, 16};
  cfg.n_atoms = 11;
  cfg.v_min = -3.0;
  cfg.v_max = 3.0;
  cfg.n_minibatches = 1;
  cfg.n_epochs = 3;
  cfg.learning_rate = 1e-2;
  return cfg;
}

}  // namespace f16race::test_support
