// Expected-SARSA targets and losses of every variant against hand-computed cases; the decoupled
// mean and the probability-space team mixture checked numerically.
#include <gtest/gtest.h>
#include <torch/torch.h>

#include <algorithm>
#include <array>
#include <cmath>

#include "agents/expected_sarsa.hpp"

namespace f16race::agents {
namespace {

const C51Support kUnused{-1.0, 1.0, 3};
constexpr double kEps = 0.1;
constexpr double kGamma = 0.5;

torch::Tensor all_true(int64_t t, int64_t n) { return torch::ones({t, n}, torch::kBool); }

// Two aircraft, 2 bins per dimension:
//   aircraft 0: dims [0, 2], [1, 1], [4, 0] -> 0.9 max + 0.1 mean = 1.9, 1.0, 3.8 -> mean 6.7/3
//   aircraft 1: dims [1, 0], [0, 0], [0, 3] -> 0.95, 0, 2.85 -> mean 3.8/3
torch::Tensor decoupled_next_q() {
  return torch::tensor({0.f, 2.f, 1.f, 1.f, 4.f, 0.f, 1.f, 0.f, 0.f, 0.f, 0.f, 3.f}).view({2, 3, 2});
}

TEST(EsVariantNames, ParseAndPrintRoundTrip) {
  for (const char* name : {"es", "es_d1", "es_d2", "es_d3"}) EXPECT_STREQ(es_variant_name(parse_es_variant(name)), name);
  EXPECT_THROW(parse_es_variant("es_d4"), std::invalid_argument);
}

TEST(EsTarget, JointVariantPerAircraft) {
  models::HlOutput next;
  // Aircraft 0: q = 4 b0 + 2 b1 + b2, greedy (1, 1, 1), each bin kept with probability 0.95:
  // 7 * 0.95 = 6.65; aircraft 1: all 1 -> 1.
  next.q = torch::cat({torch::arange(8, torch::kFloat32).view({1, 8}), torch::ones({1, 8})});
  const auto reward = torch::tensor({{1.f, 2.f}});
  auto y = es_target(EsVariant::kEs, next, reward, torch::tensor({false}), all_true(1, 2), all_true(1, 2), kEps,
                     kGamma, kUnused);
  EXPECT_NEAR(y.value[0][0].item<double>(), 1.0 + 0.5 * 6.65, 1e-5);
  EXPECT_NEAR(y.value[0][1].item<double>(), 2.0 + 0.5 * 1.0, 1e-5);
  // Episode over: the reward only. Aircraft 1 dead at the next decision: its own episode ends.
  y = es_target(EsVariant::kEs, next, reward, torch::tensor({true}), all_true(1, 2), all_true(1, 2), kEps, kGamma,
                kUnused);
  EXPECT_NEAR(y.value[0][0].item<double>(), 1.0, 1e-6);
  y = es_target(EsVariant::kEs, next, reward, torch::tensor({false}), all_true(1, 2), torch::tensor({{true, false}}),
                kEps, kGamma, kUnused);
  EXPECT_NEAR(y.value[0][0].item<double>(), 4.325, 1e-5);
  EXPECT_NEAR(y.value[0][1].item<double>(), 2.0, 1e-6);
  // Non-additive Q: 1 on the greedy joint action (1, 1, 1) only. Each dimension keeps the greedy
  // bin with probability 0.9 + 0.1 / 2 = 0.95, so E = 0.95^3 (one coin per aircraft would give
  // 0.9 + 0.1 / 8 = 0.9125).
  auto spike = torch::zeros({1, 8});
  spike[0][7] = 1.0;
  EXPECT_NEAR(egreedy_value_joint(spike, kEps)[0].item<double>(), 0.857375, 1e-6);
  EXPECT_EQ(decode_joint_index(torch::tensor({int64_t{5}}), 2)[0][0].item<int64_t>(), 1);  // 5 = 1*4 + 0*2 + 1
  EXPECT_EQ(decode_joint_index(torch::tensor({int64_t{5}}), 2)[0][1].item<int64_t>(), 0);
  EXPECT_EQ(joint_index(torch::tensor({6, 3, 5}, torch::kInt64), 7).item<int64_t>(), 6 * 49 + 3 * 7 + 5);
}

TEST(EsTarget, DecoupledPerAircraft) {
  models::HlOutput next;
  next.q = decoupled_next_q();
  EXPECT_NEAR(egreedy_value_decoupled(next.q, kEps)[0].item<double>(), 6.7 / 3.0, 1e-5);
  const auto y = es_target(EsVariant::kEsD1, next, torch::tensor({{1.f, 2.f}}), torch::tensor({false}),
                           all_true(1, 2), all_true(1, 2), kEps, kGamma, kUnused);
  EXPECT_NEAR(y.value[0][0].item<double>(), 1.0 + 0.5 * 6.7 / 3.0, 1e-5);
  EXPECT_NEAR(y.value[0][1].item<double>(), 2.0 + 0.5 * 3.8 / 3.0, 1e-5);
}

TEST(EsTarget, TeamValueVariant) {
  models::HlOutput next;
  next.q = decoupled_next_q();
  // Team reward mean(1, 2) = 1.5; team next value mean(6.7/3, 3.8/3) = 1.75.
  auto y = es_target(EsVariant::kEsD2, next, torch::tensor({{1.f, 2.f}}), torch::tensor({false}), all_true(1, 2),
                     all_true(1, 2), kEps, kGamma, kUnused);
  ASSERT_EQ(y.value.sizes(), (std::vector<int64_t>{1}));
  EXPECT_NEAR(y.value[0].item<double>(), 1.5 + 0.5 * 1.75, 1e-5);
  // Aircraft 1 dead next: the team continues on aircraft 0 alone.
  y = es_target(EsVariant::kEsD2, next, torch::tensor({{1.f, 2.f}}), torch::tensor({false}), all_true(1, 2),
                torch::tensor({{true, false}}), kEps, kGamma, kUnused);
  EXPECT_NEAR(y.value[0].item<double>(), 1.5 + 0.5 * 6.7 / 3.0, 1e-5);
}

// Atoms {-1, 0, 1}. Every dimension of aircraft 0: bin 0 p = (1, 0, 0) (Q -1), bin 1 p = (0, 0, 1)
// (Q 1, greedy); aircraft 1: bin 0 p = (0, 1, 0), bin 1 p = (.5, 0, .5), both Q 0 (tie: bin 0).
models::HlOutput distributional_next() {
  const auto p0 = torch::tensor({1.f, 0.f, 0.f, 0.f, 0.f, 1.f}).view({1, 1, 2, 3}).expand({1, 3, 2, 3});
  const auto p1 = torch::tensor({0.f, 1.f, 0.f, .5f, 0.f, .5f}).view({1, 1, 2, 3}).expand({1, 3, 2, 3});
  const auto probs = torch::cat({p0, p1}).contiguous();
  models::HlOutput out;
  out.log_probs = probs.log();  // log 0 = -inf is fine here: only exp() of it is used
  out.q = (probs * torch::tensor({-1.f, 0.f, 1.f})).sum(-1);
  return out;
}

TEST(EsTarget, DistributionalTeamMixtureAndProjection) {
  const C51Support support{-1.0, 1.0, 3};
  const auto next = distributional_next();
  // Per aircraft: 0.9 p(greedy) + 0.1 mean_b p(b):
  //   aircraft 0: 0.9 (0, 0, 1) + 0.1 (.5, 0, .5) = (.05, 0, .95)
  //   aircraft 1: 0.9 (0, 1, 0) + 0.1 (.25, .5, .25) = (.025, .95, .025)
  const auto mix = egreedy_mixture_decoupled(next.log_probs, next.q, kEps);
  const double want0[3] = {.05, 0, .95}, want1[3] = {.025, .95, .025};
  for (int k = 0; k < 3; ++k) {
    EXPECT_NEAR(mix[0][k].item<double>(), want0[k], 1e-6);
    EXPECT_NEAR(mix[1][k].item<double>(), want1[k], 1e-6);
  }
  // Team mixture (.0375, .475, .4875); team reward mean(1, 0) = 0.5; Tz = 0.5 + 0.5 z = (0, .5, 1):
  // atom 0's mass to atom 1, atom 1's split evenly over atoms 1 and 2, atom 2's stays.
  const auto y = es_target(EsVariant::kEsD3, next, torch::tensor({{1.f, 0.f}}), torch::tensor({false}),
                           all_true(1, 2), all_true(1, 2), kEps, kGamma, support);
  ASSERT_EQ(y.dist.sizes(), (std::vector<int64_t>{1, 3}));
  EXPECT_NEAR(y.dist[0][0].item<double>(), 0.0, 1e-6);
  EXPECT_NEAR(y.dist[0][1].item<double>(), 0.0375 + 0.2375, 1e-6);
  EXPECT_NEAR(y.dist[0][2].item<double>(), 0.2375 + 0.4875, 1e-6);
  EXPECT_NEAR(y.value[0].item<double>(), 0.725, 1e-6);
  // Terminal: all mass on r = 0.5, half on atom 1 and half on atom 2.
  const auto y_done = es_target(EsVariant::kEsD3, next, torch::tensor({{1.f, 0.f}}), torch::tensor({true}),
                                all_true(1, 2), all_true(1, 2), kEps, kGamma, support);
  EXPECT_NEAR(y_done.dist[0][1].item<double>(), 0.5, 1e-6);
  EXPECT_NEAR(y_done.dist[0][2].item<double>(), 0.5, 1e-6);
}

TEST(EsLoss, DecoupledMeanAndTeamValue) {
  auto gen = models::make_generator(5);
  const int64_t t = 4, n_a = 3, bins = 7;
  models::HlOutput out;
  out.q = torch::randn({t * n_a, 3, bins}, gen, torch::kFloat32);
  const auto actions = torch::randint(0, bins, {t, n_a, 3}, gen, torch::kInt64);
  auto active = all_true(t, n_a);
  active[2][1] = false;
  // Explicit sum: Q^{i} = 1/3 sum_j Q^{i,j}(a^{i,j}), team = mean over active aircraft.
  auto per_aircraft = torch::zeros({t, n_a});
  for (int64_t s = 0; s < t; ++s)
    for (int64_t i = 0; i < n_a; ++i) {
      double sum = 0.0;
      for (int64_t j = 0; j < 3; ++j) sum += out.q[s * n_a + i][j][actions[s][i][j].item<int64_t>()].item<double>();
      per_aircraft[s][i] = sum / 3.0;
    }
  EsTarget y1{torch::zeros({t, n_a}), {}};
  const auto l1 = es_loss(EsVariant::kEsD1, out, actions, active, y1, 1.0, kUnused);
  EXPECT_LT((l1.prediction - per_aircraft).abs().max().item<double>(), 1e-5);
  // Huber with delta 1 against 0, averaged over the 11 active aircraft.
  const auto h = torch::where(per_aircraft.abs() < 1.0, 0.5 * per_aircraft.pow(2), per_aircraft.abs() - 0.5);
  EXPECT_NEAR(l1.loss.item<double>(), (h * active).sum().item<double>() / 11.0, 1e-5);

  EsTarget y2{torch::full({t}, 0.25f), {}};
  const auto l2 = es_loss(EsVariant::kEsD2, out, actions, active, y2, 1.0, kUnused);
  for (int64_t s = 0; s < t; ++s) {
    const double team = s == 2 ? (per_aircraft[s][0].item<double>() + per_aircraft[s][2].item<double>()) / 2.0
                               : per_aircraft[s].mean().item<double>();
    EXPECT_NEAR(l2.prediction[s].item<double>(), team, 1e-5) << "team sample " << s;
  }

  // Joint variant: the Q of the joint index b0 * 49 + b1 * 7 + b2.
  models::HlOutput joint;
  joint.q = torch::randn({t * n_a, 343}, gen, torch::kFloat32);
  const auto l0 = es_loss(EsVariant::kEs, joint, actions, active, y1, 1.0, kUnused);
  const auto a = actions[1][2];
  const int64_t idx = a[0].item<int64_t>() * 49 + a[1].item<int64_t>() * 7 + a[2].item<int64_t>();
  EXPECT_FLOAT_EQ(l0.prediction[1][2].item<float>(), joint.q[1 * n_a + 2][idx].item<float>());
}

TEST(EsLoss, DistributionalTeamMixtureCrossEntropy) {
  auto gen = models::make_generator(6);
  const int64_t t = 3, n_a = 2, bins = 7, k = 11;
  const C51Support support{-2.0, 2.0, k};
  models::HlOutput out;
  out.log_probs = torch::log_softmax(torch::randn({t * n_a, 3, bins, k}, gen, torch::kFloat32), -1);
  out.q = (out.log_probs.exp() * support.atoms()).sum(-1);
  const auto actions = torch::randint(0, bins, {t, n_a, 3}, gen, torch::kInt64);
  EsTarget y;
  y.dist = torch::softmax(torch::randn({t, k}, gen, torch::kFloat32), 1);
  y.value = (y.dist * support.atoms()).sum(1);
  const auto l = es_loss(EsVariant::kEsD3, out, actions, all_true(t, n_a), y, 1.0, support);
  // Explicit mixture: p_team = 1/(3 n_a) sum_{i,j} p^{i,j}(a^{i,j}) (paper Eq. 2); Q = sum_k z_k p_k (Eq. 3).
  double ce = 0.0;
  for (int64_t s = 0; s < t; ++s) {
    auto p_team = torch::zeros({k});
    for (int64_t i = 0; i < n_a; ++i)
      for (int64_t j = 0; j < 3; ++j)
        p_team += out.log_probs[s * n_a + i][j][actions[s][i][j].item<int64_t>()].exp() / (3.0 * n_a);
    EXPECT_NEAR(p_team.sum().item<double>(), 1.0, 1e-5);
    EXPECT_NEAR(l.prediction[s].item<double>(), (p_team * support.atoms()).sum().item<double>(), 1e-5);
    ce -= (y.dist[s] * p_team.log()).sum().item<double>();
  }
  EXPECT_NEAR(l.loss.item<double>(), ce / t, 1e-5);
  // Optional per-component term: + w * mean over (team, aircraft, dimension) of -sum_k m_k log p^{i,j}_k.
  double component_ce = 0.0;
  for (int64_t s = 0; s < t; ++s)
    for (int64_t i = 0; i < n_a; ++i)
      for (int64_t j = 0; j < 3; ++j)
        component_ce -= (y.dist[s] * out.log_probs[s * n_a + i][j][actions[s][i][j].item<int64_t>()]).sum().item<double>();
  const auto lw = es_loss(EsVariant::kEsD3, out, actions, all_true(t, n_a), y, 1.0, support, 0.5);
  EXPECT_NEAR(lw.loss.item<double>(), ce / t + 0.5 * component_ce / (t * n_a * 3), 1e-5);
}

// hl.d3_loss huber_mean (the paper's Eq. 5 read literally): Huber on the mixture's expected value
// against the target's mean, over valid teams; its gradient reaches each taken component through
// d Q / d log p^{i,j}_k = p^{i,j}_k z_k / (3 n_active).
TEST(EsLoss, DistributionalHuberOnTheMixturesMean) {
  auto gen = models::make_generator(7);
  const int64_t t = 4, n_a = 2, bins = 7, k = 11;
  const C51Support support{-2.0, 2.0, k};
  const auto logits = torch::randn({t * n_a, 3, bins, k}, gen, torch::kFloat32);
  models::HlOutput out;
  out.log_probs = torch::log_softmax(logits, -1).detach().requires_grad_(true);
  out.q = (out.log_probs.detach().exp() * support.atoms()).sum(-1);
  const auto actions = torch::randint(0, bins, {t, n_a, 3}, gen, torch::kInt64);
  auto active = all_true(t, n_a);
  active[1][0] = false;                 // a team of one
  active[3][0] = active[3][1] = false;  // no team: left out
  EsTarget y;
  y.dist = torch::softmax(torch::randn({t, k}, gen, torch::kFloat32), 1);
  y.value = torch::tensor({1.9f, -0.2f, 0.1f, 0.5f});  // team 0's error beyond delta 1, the others inside
  const auto ce = es_loss(EsVariant::kEsD3, out, actions, active, y, 1.0, support);
  const auto l = es_loss(EsVariant::kEsD3, out, actions, active, y, 1.0, support, 0.0, D3Loss::kHuberMean);
  EXPECT_TRUE(torch::equal(l.prediction, ce.prediction));
  double want = 0.0;
  for (int64_t s = 0; s < 3; ++s) {
    const double d = l.prediction[s].item<double>() - y.value[s].item<double>();
    want += std::abs(d) <= 1.0 ? 0.5 * d * d : std::abs(d) - 0.5;
  }
  ASSERT_GT(std::abs(l.prediction[0].item<double>() - 1.9), 1.0);
  EXPECT_NEAR(l.loss.item<double>(), want / 3, 1e-6);
  l.loss.backward();
  const auto g = out.log_probs.grad();
  const auto p = out.log_probs.detach().exp();
  for (int64_t s = 0; s < t; ++s)
    for (int64_t i = 0; i < n_a; ++i) {
      const int64_t members = s == 1 ? 1 : 2;
      const double d = s < 3 ? l.prediction[s].item<double>() - y.value[s].item<double>() : 0.0;
      const double slope = std::max(-1.0, std::min(1.0, d)) / 3.0 / (3.0 * members);
      for (int64_t j = 0; j < 3; ++j) {
        const int64_t a = actions[s][i][j].item<int64_t>();
        const bool counts = s < 3 && active[s][i].item<bool>();
        for (int64_t c = 0; c < k; c += 5) {
          const double z = support.v_min + support.delta() * static_cast<double>(c);
          const double want_g = counts ? slope * p[s * n_a + i][j][a][c].item<double>() * z : 0.0;
          EXPECT_NEAR(g[s * n_a + i][j][a][c].item<double>(), want_g, 1e-6) << s << i << j << c;
        }
      }
    }
}

}  // namespace
}  // namespace f16race::agents

// --- diagnostics of the high level (metrics.csv: q_spread, greedy_entropy, off_center_share, middle_share_*,
// es_end_atom_share, es_huber_share) ------------------------------------------------------------
namespace f16race::agents {
namespace {

TEST(EsDiagnostics, SpreadEntropyAndOffCenterShareOfHandMadeUtilities) {
  // 2 rows, 3 dims, 3 bins (middle bin 1). Greedy: row 0 (2, 1, 0), row 1 (1, 1, 1).
  const auto q = torch::tensor({0.f, 1.f, 3.f, /**/ 0.f, 2.f, 0.f, /**/ 5.f, 1.f, 4.f,  //
                                0.f, 1.f, 0.f, /**/ 1.f, 4.f, 3.f, /**/ 0.f, 2.f, 1.f})
                       .view({2, 3, 3});
  EsStats s;
  es_policy_diagnostics(q, 3, &s);
  // Spreads: row 0: 3, 2, 4; row 1: 1, 3, 2 -> mean 15/6.
  EXPECT_NEAR(s.q_spread, 2.5, 1e-6);
  // Greedy bins per dim over the 2 rows: {2, 1}, {1, 1}, {0, 1} -> ln2, 0, ln2, / ln3, mean.
  EXPECT_NEAR(s.greedy_entropy, (2.0 * std::log(2.0) / std::log(3.0)) / 3.0, 1e-9);
  EXPECT_NEAR(s.off_center_share, 0.5, 1e-12);
  // Middle bin per dim: {no, yes}, {yes, yes}, {no, yes}.
  EXPECT_NEAR(s.middle_share[0], 0.5, 1e-12);
  EXPECT_NEAR(s.middle_share[1], 1.0, 1e-12);
  EXPECT_NEAR(s.middle_share[2], 0.5, 1e-12);
  // Joint utilities: greedy decoded from the argmax over n_bins^3.
  auto joint = torch::zeros({2, 27});
  joint[0][1 * 9 + 1 * 3 + 1] = 1.0;  // (1, 1, 1): the middle
  joint[1][2 * 9 + 1 * 3 + 1] = 3.0;  // (2, 1, 1)
  es_policy_diagnostics(joint, 3, &s);
  EXPECT_NEAR(s.q_spread, 2.0, 1e-6);
  EXPECT_NEAR(s.off_center_share, 0.5, 1e-12);
  EXPECT_NEAR(s.greedy_entropy, (std::log(2.0) / std::log(3.0)) / 3.0, 1e-9);
  EXPECT_NEAR(s.middle_share[0], 0.5, 1e-12);
  EXPECT_NEAR(s.middle_share[1], 1.0, 1e-12);
  EXPECT_NEAR(s.middle_share[2], 1.0, 1e-12);
}

// Terminal single-decision teams with known team rewards {-2, -0.5, 0, 0.5, 2}: with the
// support [-1, 1] (21 atoms, 0.1 apart) the two outer rewards are clipped onto the end atoms,
// the others land on inner atoms, so 2 / 5 of the target mass is on the end atoms; a support
// that holds every return ([-3, 3]) puts none there. The value variants' share of TD errors
// beyond the Huber delta (1) counts the same two teams, the critic starting near 0.
EsStats toy_update(EsVariant v, double v_bound) {
  torch::manual_seed(5);
  EsConfig cfg;
  cfg.variant = v;
  cfg.dims = models::ObsDims{4, 2, 2, 1};
  cfg.d_model = 8;
  cfg.n_heads = 2;
  cfg.hidden = {16, 16};
  cfg.n_atoms = 21;
  cfg.v_min = -v_bound;
  cfg.v_max = v_bound;
  EsAgent agent(cfg);
  const int64_t t = 5, n = 2;
  auto obs = [&] {
    return models::HlObs{torch::randn({t, n, 4}), torch::zeros({t, n, 3}), torch::randn({t, n, 1, 2}),
                         torch::ones({t, n, 1}, torch::kBool), torch::randn({t, n, 2})};
  };
  EsBatch b;
  b.obs = obs();
  b.next_obs = obs();
  b.actions = torch::full({t, n, 3}, 3, torch::kInt64);
  b.reward = torch::tensor({-2.f, -0.5f, 0.f, 0.5f, 2.f}).view({t, 1}).expand({t, n}).contiguous();
  b.done = torch::ones({t}, torch::kBool);
  return agent.update(b);
}

TEST(EsDiagnostics, EndAtomShareCountsTargetsOutsideTheSupport) {
  EXPECT_NEAR(toy_update(EsVariant::kEsD3, 1.0).end_atom_share, 0.4, 1e-6);
  EXPECT_NEAR(toy_update(EsVariant::kEsD3, 3.0).end_atom_share, 0.0, 1e-6);
  EXPECT_TRUE(std::isnan(toy_update(EsVariant::kEsD3, 3.0).huber_share));
}

TEST(EsDiagnostics, HuberShareCountsTdErrorsBeyondDelta) {
  for (const EsVariant v : {EsVariant::kEs, EsVariant::kEsD1, EsVariant::kEsD2}) {
    const EsStats s = toy_update(v, 3.0);
    EXPECT_NEAR(s.huber_share, 0.4, 1e-6) << es_variant_name(v);
    EXPECT_TRUE(std::isnan(s.end_atom_share));
    EXPECT_EQ(s.grad_steps, 1);
    EXPECT_GT(s.loss_before, 0.0);
  }
}

// Exploration per aircraft and goal axis (the paper's): eps 0 is greedy; at eps each row and
// axis leaves its greedy bin with probability eps (n_bins - 1) / n_bins, on a uniform bin; the
// rows draw apart, so a team's aircraft rarely share an explored bin.
TEST(EsExploration, EachAircraftAndAxisDrawsItsOwnCoin) {
  torch::manual_seed(3);
  EsConfig cfg;
  cfg.variant = EsVariant::kEsD2;
  cfg.dims = models::ObsDims{4, 2, 2, 1};
  cfg.d_model = 8;
  cfg.n_heads = 2;
  cfg.hidden = {16, 16};
  EsAgent agent(cfg);
  const int64_t b = 6000, team = 3;
  auto input_gen = models::make_generator(9);
  const models::HlObs obs{torch::randn({b, 4}, input_gen), torch::zeros({b, 3}), torch::randn({b, 1, 2}, input_gen),
                          torch::ones({b, 1}, torch::kBool), torch::randn({b, 2}, input_gen)};
  auto gen = models::make_generator(4);
  const EsAction greedy = agent.act(obs, 0.0, gen);
  EXPECT_TRUE(greedy.bins.equal(greedy.greedy_bins));
  EXPECT_TRUE(greedy.greedy_bins.equal(greedy.q.argmax(2)));
  {  // eps 1: every axis explores, uniform over the 7 bins
    const auto bins = agent.act(obs, 1.0, gen).bins;
    const auto count = torch::bincount(bins.reshape({-1}), {}, 7).to(torch::kFloat64);
    const double expected = static_cast<double>(b * 3) / 7.0;
    EXPECT_LT(((count - expected).pow(2) / expected).sum().item<double>(), 22.46);  // chi2, 6 dof, 0.999
    const auto by_team = bins.view({b / team, team, 3});
    // Three independent uniform bins agree 1 / 49 of the time.
    EXPECT_LT(by_team.eq(by_team.select(1, 0).unsqueeze(1)).all(1).to(torch::kFloat64).mean().item<double>(), 0.1);
  }
  const EsAction a = agent.act(obs, 0.3, gen);
  const auto off = a.bins.ne(a.greedy_bins).to(torch::kFloat64).mean(0);  // [3]
  for (int j = 0; j < 3; ++j) EXPECT_NEAR(off[j].item<double>(), 0.3 * 6.0 / 7.0, 0.02) << "axis " << j;  // sd 0.006
}

}  // namespace
}  // namespace f16race::agents
