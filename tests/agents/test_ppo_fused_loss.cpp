// The fused PPO loss (agents/ppo_fused_loss.hpp) against the composed LibTorch ops it replaces in
// PpoAgent::update (gaussian_log_prob, gaussian_entropy, ppo_loss): the same value, terms and
// gradients with respect to the network's outputs, with clipping active and inactive, ratio ties,
// value clipping on and off, an entropy bonus and a chunk weight.
#include <gtest/gtest.h>
#include <torch/torch.h>

#include "agents/ppo.hpp"
#include "agents/ppo_fused_loss.hpp"
#include "models/ll_actor_critic.hpp"

namespace f16race::agents {
namespace {

struct Case {
  torch::Tensor mean, log_std_param, value, action, old_log_prob, advantages, old_value, returns;
};

// M rows of A = 4 actions; old log-probabilities near the new ones so that some ratios are clipped
// (|r - 1| > 0.2), some not, and `ties` rows exactly at ratio 1 (old = new).
Case make_case(int64_t m, int ties, uint64_t seed) {
  torch::manual_seed(seed);
  Case c;
  c.mean = torch::randn({m, 4});
  c.log_std_param = torch::randn({4}) * 0.3 - 0.5;
  c.value = torch::randn({m});
  c.action = c.mean + torch::randn({m, 4}) * c.log_std_param.exp();
  {
    const auto lp = models::gaussian_log_prob(c.mean, c.log_std_param.expand({m, 4}), c.action);
    c.old_log_prob = lp + torch::randn({m}) * 0.3;
    c.old_log_prob.slice(0, 0, ties).copy_(lp.slice(0, 0, ties));
  }
  c.advantages = torch::randn({m});
  c.old_value = c.value + torch::randn({m}) * 0.3;  // some |V - V_old| beyond 0.2
  c.returns = torch::randn({m});
  return c;
}

void expect_same(const Case& c, const PpoConfig& cfg, double weight) {
  const int64_t m = c.mean.size(0);
  // Oracle: the composed ops.
  auto mean_o = c.mean.clone().requires_grad_(), ls_o = c.log_std_param.clone().requires_grad_(),
       v_o = c.value.clone().requires_grad_();
  const auto log_std_o = ls_o.expand({m, 4});
  const auto lp = models::gaussian_log_prob(mean_o, log_std_o, c.action);
  const auto oracle = ppo_loss(lp, c.old_log_prob, c.advantages, v_o, c.old_value, c.returns,
                               models::gaussian_entropy(log_std_o), cfg);
  (oracle.total * weight).backward();
  // Fused.
  auto mean_f = c.mean.clone().requires_grad_(), ls_f = c.log_std_param.clone().requires_grad_(),
       v_f = c.value.clone().requires_grad_();
  const auto fused = fused_ppo_loss(mean_f, ls_f.expand({m, 4}), v_f, c.action, c.old_log_prob, c.advantages,
                                    c.old_value, c.returns, cfg, weight);
  fused.total.backward();
  EXPECT_NEAR(fused.total.item<double>(), (oracle.total * weight).item<double>(), 2e-6);
  EXPECT_NEAR(fused.policy_loss, oracle.policy_loss.item<double>(), 2e-6);
  EXPECT_NEAR(fused.value_loss, oracle.value_loss.item<double>(), 2e-6);
  EXPECT_NEAR(fused.entropy, oracle.entropy.item<double>(), 2e-6);
  EXPECT_NEAR(fused.approx_kl, oracle.approx_kl.item<double>(), 2e-6);
  EXPECT_NEAR(fused.clip_fraction, oracle.clip_fraction.item<double>(), 1e-7);  // the oracle's is a float mean
  EXPECT_TRUE(torch::allclose(mean_f.grad(), mean_o.grad(), 1e-4, 1e-7)) << (mean_f.grad() - mean_o.grad()).abs().max();
  EXPECT_TRUE(torch::allclose(ls_f.grad(), ls_o.grad(), 1e-4, 1e-7)) << ls_f.grad() << ls_o.grad();
  EXPECT_TRUE(torch::allclose(v_f.grad(), v_o.grad(), 1e-4, 1e-7)) << (v_f.grad() - v_o.grad()).abs().max();
  // The case exercised both sides of the clip.
  EXPECT_GT(fused.clip_fraction, 0.05);
  EXPECT_LT(fused.clip_fraction, 0.95);
}

TEST(PpoFusedLoss, EqualsTheComposedLossAndItsGradients) {
  PpoConfig cfg;
  cfg.normalize_advantages = false;
  expect_same(make_case(300, 20, 1), cfg, 1.0);
  cfg.clip_value_loss = false;
  expect_same(make_case(77, 5, 2), cfg, 1.0);
  cfg.clip_value_loss = true;
  cfg.ent_coef = 0.01;
  cfg.vf_coef = 0.7;
  expect_same(make_case(129, 0, 3), cfg, 0.375);
}

TEST(PpoFusedLoss, RefusesAdvantagesItWouldHaveToNormalise) {
  PpoConfig cfg;  // normalize_advantages on
  const Case c = make_case(8, 0, 4);
  EXPECT_THROW(fused_ppo_loss(c.mean, c.log_std_param.expand({8, 4}), c.value, c.action, c.old_log_prob,
                              c.advantages, c.old_value, c.returns, cfg),
               c10::Error);
}

}  // namespace
}  // namespace f16race::agents
