// The fused ES+D2 and ES+D3 losses (agents/es_fused_loss.hpp) against es_loss, the composed
// LibTorch ops they replace in EsAgent::update: the same loss, prediction statistics and gradient
// with respect to the critic's output, with inactive members, a team with none active, and a weight.
#include <gtest/gtest.h>
#include <torch/torch.h>

#include "agents/es_fused_loss.hpp"
#include "agents/expected_sarsa.hpp"

namespace f16race::agents {
namespace {

TEST(EsD2FusedLoss, EqualsEsLossAndItsGradient) {
  torch::manual_seed(11);
  const int64_t t = 9, n_a = 4, n_bins = 7;
  const auto q_values = torch::randn({t * n_a, 3, n_bins}) * 2.0;
  const auto actions = torch::randint(0, n_bins, {t, n_a, 3}, torch::kInt64);
  auto active = torch::rand({t, n_a}) > 0.3;
  active[2].fill_(false);  // a team with no active member: outside the loss
  active[5].fill_(true);
  active[6].fill_(false);
  active[6][1] = true;  // a team of one
  // Targets at set distances from the teams' predictions, so that both of Huber's branches occur at
  // delta 1 and 0.25 (none at a zero residual, whose gradient is 0).
  models::HlOutput plain;
  plain.q = q_values;
  const auto prediction =
      es_loss(EsVariant::kEsD2, plain, actions, active, EsTarget{torch::zeros({t}), {}}, 1.0, C51Support{}).prediction;
  const auto target_value = prediction + torch::linspace(-2.1, 1.9, t);
  for (const double delta : {1.0, 0.25})
    for (const double weight : {1.0, 0.4}) {
      auto q_o = q_values.clone().requires_grad_();
      models::HlOutput out_o;
      out_o.q = q_o;
      const auto l = es_loss(EsVariant::kEsD2, out_o, actions, active, EsTarget{target_value, {}}, delta, C51Support{});
      (l.loss * weight).backward();
      const auto valid = l.valid.to(torch::kFloat32);
      const auto residual = (l.prediction - target_value).abs();
      const double q_ref = ((l.prediction * valid).sum() / valid.sum()).item<double>();
      const double td_ref = ((residual * valid).sum() / valid.sum()).item<double>();
      // Both branches present: the test covers the quadratic and the linear part.
      ASSERT_GT(((residual > delta).logical_and(l.valid)).sum().item<int64_t>(), 0);
      ASSERT_GT(((residual < delta).logical_and(l.valid)).sum().item<int64_t>(), 0);

      auto q_f = q_values.clone().requires_grad_();
      const auto f = fused_es_d2_loss(q_f, actions, active, target_value, delta, weight);
      f.total.backward();
      EXPECT_NEAR(f.loss, l.loss.item<double>(), 1e-5);
      EXPECT_NEAR(f.total.item<double>(), weight * l.loss.item<double>(), 1e-5);
      EXPECT_NEAR(f.q, q_ref, 1e-5);
      EXPECT_NEAR(f.td, td_ref, 1e-5);
      EXPECT_TRUE(torch::allclose(q_f.grad(), q_o.grad(), 1e-5, 1e-8)) << (q_f.grad() - q_o.grad()).abs().max();
      // Only the taken bins of active members carry a gradient.
      EXPECT_EQ((q_f.grad() != 0).sum().item<int64_t>(), 3 * active.sum().item<int64_t>());
    }
}

TEST(EsD2FusedLoss, RefusesBadInputs) {
  auto actions = torch::zeros({1, 2, 3}, torch::kInt64);
  const auto active = torch::ones({1, 2}, torch::kBool);
  EXPECT_NO_THROW(fused_es_d2_loss(torch::zeros({2, 3, 7}), actions, active, torch::zeros({1}), 1.0));
  EXPECT_THROW(fused_es_d2_loss(torch::zeros({2, 3, 7}), actions, active, torch::zeros({1}), 0.0), c10::Error);
  EXPECT_THROW(fused_es_d2_loss(torch::zeros({3, 3, 7}), actions, active, torch::zeros({1}), 1.0), c10::Error);
  EXPECT_THROW(fused_es_d2_loss(torch::zeros({2, 3, 7}), actions, active, torch::zeros({2}), 1.0), c10::Error);
  actions[0][1][2] = 7;
  EXPECT_THROW(fused_es_d2_loss(torch::zeros({2, 3, 7}), actions, active, torch::zeros({1}), 1.0), c10::Error);
}

TEST(EsD3FusedLoss, EqualsEsLossAndItsGradient) {
  torch::manual_seed(7);
  const int64_t t = 9, n_a = 4, n_bins = 7, k = 21;
  const C51Support support{-8.5, 8.5, k};
  const auto logits = torch::randn({t * n_a, 3, n_bins, k}) * 2.0;
  const auto actions = torch::randint(0, n_bins, {t, n_a, 3}, torch::kInt64);
  auto active = torch::rand({t, n_a}) > 0.3;
  active[2].fill_(false);  // a team with no active member: outside the loss
  active[5].fill_(true);
  const auto target_dist = torch::softmax(torch::randn({t, k}), 1);
  const auto target_value = (target_dist * support.atoms()).sum(1);
  for (const double weight : {1.0, 0.4}) {
    auto lp_o = torch::log_softmax(logits, -1).detach().requires_grad_();
    models::HlOutput out_o;
    out_o.log_probs = lp_o;
    out_o.q = (lp_o.exp() * support.atoms()).sum(-1);
    const auto l = es_loss(EsVariant::kEsD3, out_o, actions, active, EsTarget{target_value, target_dist}, 1.0, support);
    (l.loss * weight).backward();
    const auto valid = l.valid.to(torch::kFloat32);
    const double q_o = ((l.prediction * valid).sum() / valid.sum()).item<double>();
    const double td_o = (((l.prediction - target_value).abs() * valid).sum() / valid.sum()).item<double>();

    auto lp_f = torch::log_softmax(logits, -1).detach().requires_grad_();
    const auto f = fused_es_d3_loss(lp_f, actions, active, target_dist, target_value, support, weight);
    f.total.backward();
    EXPECT_NEAR(f.loss, l.loss.item<double>(), 2e-5);
    EXPECT_NEAR(f.total.item<double>(), weight * l.loss.item<double>(), 2e-5);
    EXPECT_NEAR(f.q, q_o, 2e-5);
    EXPECT_NEAR(f.td, td_o, 2e-5);
    EXPECT_TRUE(torch::allclose(lp_f.grad(), lp_o.grad(), 1e-4, 1e-7))
        << (lp_f.grad() - lp_o.grad()).abs().max();
    // Only the taken bins of active members carry a gradient.
    EXPECT_EQ((lp_f.grad() != 0).sum().item<int64_t>(), 3 * k * active.sum().item<int64_t>());
  }
}

TEST(EsD3FusedLoss, RefusesABinOutsideTheCritic) {
  const C51Support support{-1.0, 1.0, 5};
  auto actions = torch::zeros({1, 2, 3}, torch::kInt64);
  actions[0][1][2] = 7;
  EXPECT_THROW(fused_es_d3_loss(torch::zeros({2, 3, 7, 5}), actions, torch::ones({1, 2}, torch::kBool),
                                torch::full({1, 5}, 0.2), torch::zeros({1}), support),
               c10::Error);
}

}  // namespace
}  // namespace f16race::agents
