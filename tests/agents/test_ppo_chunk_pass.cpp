// PPO's update through the fused training pass (agents/ppo_chunk_pass.hpp) against the same update
// through LibTorch's autograd (PpoConfig::fused_training false, the oracle): one buffer with dead
// aircraft and samples with nobody alive, chunked minibatches, several epochs.
#include <gtest/gtest.h>
#include <omp.h>
#include <torch/torch.h>

#include <algorithm>
#include <cmath>
#include <string>
#include <memory>
#include <vector>

#include "agents/ppo.hpp"
#include "agents/rollout_buffer.hpp"
#include "models/obs.hpp"

namespace f16race::agents {
namespace {

RolloutBuffer chunk_pass_buffer(const PpoConfig& cfg, int64_t n) {
  const models::ObsDims& d = cfg.net.dims;
  auto gen = models::make_generator(31);
  RolloutBuffer buffer(cfg.n_steps, n, d);
  for (int64_t t = 0; t < cfg.n_steps; ++t) {
    auto alive = torch::rand({n, d.n_other}, gen) < 0.7;
    alive[0].fill_(false);  // nobody else alive for this aircraft
    const models::LlObs obs{torch::randn({n, d.d_ego}, gen), torch::randn({n, d.d_goal}, gen),
                            torch::randn({n, d.n_other, d.d_ado}, gen), alive, torch::randn({n, d.d_task}, gen)};
    buffer.add(obs, torch::randn({n, 3}, gen), torch::randn({n}, gen) - 3.0f, torch::randn({n}, gen),
               torch::randn({n}, gen), torch::zeros({n}, torch::kBool), torch::zeros({n}, torch::kBool),
               torch::Tensor(), torch::rand({n}, gen) < 0.9);  // some aircraft dead: left out
  }
  buffer.finish(torch::zeros({n}), cfg.gamma, cfg.gae_lambda);
  return buffer;
}

PpoConfig chunk_pass_config() {
  PpoConfig cfg;
  cfg.net.dims = models::ObsDims{12, 6, 4, 3};
  cfg.net.d_model = 32;
  cfg.net.n_heads = 2;
  cfg.n_steps = 16;
  cfg.total_updates = 2;
  cfg.max_chunk_rows = 20;  // ~60-row minibatches in three chunks
  cfg.ent_coef = 0.01;      // the entropy's gradient reaches log_std too
  return cfg;
}

TEST(PpoChunkPass, FusedUpdateEqualsTheAutogradUpdate) {
  PpoConfig cfg = chunk_pass_config();
  const RolloutBuffer buffer = chunk_pass_buffer(cfg, 16);
  std::vector<std::unique_ptr<PpoAgent>> agents;
  std::vector<PpoStats> stats;
  std::vector<torch::Tensor> initial;
  for (bool fused : {true, false}) {
    torch::manual_seed(3);
    cfg.fused_training = fused;
    agents.push_back(std::make_unique<PpoAgent>(cfg));
    if (fused)
      for (const auto& p : agents.back()->net()->parameters()) initial.push_back(p.detach().clone());
    for (int u = 0; u < 2; ++u) stats.push_back(agents.back()->update(buffer));
  }
  EXPECT_EQ(stats[1].train_passes, stats[3].train_passes);
  EXPECT_GT(stats[1].train_passes, stats[1].grad_steps);  // chunked
  EXPECT_NEAR(stats[1].policy_loss, stats[3].policy_loss, 1e-5);
  EXPECT_NEAR(stats[1].value_loss, stats[3].value_loss, 1e-4 * (1.0 + std::abs(stats[3].value_loss)));
  EXPECT_NEAR(stats[1].approx_kl, stats[3].approx_kl, 1e-6);
  EXPECT_NEAR(stats[1].entropy, stats[3].entropy, 1e-6);
  const auto oracle = agents[1]->net()->named_parameters();
  std::size_t i = 0;
  for (const auto& item : agents[0]->net()->named_parameters()) {
    // 2 updates x 16 steps of ~lr = 3e-4 each: every weight moved; the two paths agree to
    // float rounding (Adam divides by sqrt(v), so rounding in tiny gradients shows most).
    EXPECT_LT((item.value() - oracle[item.key()]).abs().max().item<double>(), 2e-5) << item.key();
    // Every weight moved, but the key bias: the softmax cancels it (its gradient is rounding).
    const double moved = (item.value() - initial[i++]).abs().max().item<double>();
    if (item.key() != "encoder.k_proj.bias") {
      EXPECT_GT(moved, 1e-4) << item.key();
    }
  }
}

TEST(PpoChunkPass, SameBitsAtOneAndTwoThreads) {
  PpoConfig cfg = chunk_pass_config();
  const RolloutBuffer buffer = chunk_pass_buffer(cfg, 16);
  const int threads = omp_get_max_threads();
  std::vector<torch::OrderedDict<std::string, torch::Tensor>> params;
  for (int t : {1, 2}) {
    omp_set_num_threads(t);
    torch::manual_seed(3);
    PpoAgent agent(cfg);
    agent.update(buffer);
    params.push_back(agent.net()->named_parameters());
  }
  omp_set_num_threads(threads);
  for (const auto& item : params[0]) EXPECT_TRUE(item.value().equal(params[1][item.key()])) << item.key();
}

}  // namespace
}  // namespace f16race::agents
