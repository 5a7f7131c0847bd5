// Expected-SARSA targets and losses of every variant against hand-computed cases; the decoupled
// mean and the probability-space team mixture checked numerically.
#include <gtest/gtest.h>
#include <torch/torch.h>

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

// hl.team_target: per_axis (es_d2). One target per team and axis, r + gamma mean_i V^{i,j}, whose
// mean over the axes is the paper's single target; the loss fits each axis's team mean of the
// taken utilities to its own target, so axes that err in opposite directions no longer cancel.
TEST(EsTarget, PerAxisTeamTargetAndLoss) {
  auto gen = models::make_generator(12);
  const int64_t t = 3, n_a = 2, bins = 5;
  models::HlOutput next;
  next.q = torch::randn({t * n_a, 3, bins}, gen, torch::kFloat32);
  const auto reward = torch::randn({t, n_a}, gen, torch::kFloat32);
  const auto done = torch::tensor({false, true, false});
  auto next_active = all_true(t, n_a);
  next_active[2][1] = false;
  const auto y = es_target(EsVariant::kEsD2, next, reward, done, all_true(t, n_a), next_active, kEps, kGamma, kUnused,
                           EsTargetRule{/*per_axis_target=*/true});
  ASSERT_EQ(y.value.sizes(), (std::vector<int64_t>{t, 3}));
  for (int64_t s = 0; s < t; ++s)
    for (int64_t j = 0; j < 3; ++j) {
      double v = 0.0;
      int64_t n = 0;
      for (int64_t i = 0; i < n_a; ++i) {
        if (!next_active[s][i].item<bool>()) continue;
        const auto qj = next.q[s * n_a + i][j];
        v += (1.0 - kEps) * qj.max().item<double>() + kEps * qj.mean().item<double>();
        ++n;
      }
      const double live = done[s].item<bool>() ? 0.0 : 1.0;
      EXPECT_NEAR(y.value[s][j].item<double>(), reward[s].mean().item<double>() + kGamma * live * v / n, 1e-5)
          << "team " << s << " axis " << j;
    }
  // The paper's target is the mean of the three.
  const auto y_sum = es_target(EsVariant::kEsD2, next, reward, done, all_true(t, n_a), next_active, kEps, kGamma, kUnused);
  EXPECT_LT((y.value.mean(1) - y_sum.value).abs().max().item<double>(), 1e-5);

  // One team of one aircraft: utilities 1 (x), -1 (y), 0 (z) on the taken bins, targets 0: the
  // mean over the axes fits exactly, the axes do not.
  models::HlOutput out;
  out.q = torch::zeros({1, 3, bins});
  out.q[0][0][2] = 1.0;
  out.q[0][1][2] = -1.0;
  const auto actions = torch::full({1, 1, 3}, int64_t{2});
  const auto l_sum = es_loss(EsVariant::kEsD2, out, actions, all_true(1, 1), EsTarget{torch::zeros({1}), {}}, 1.0, kUnused);
  const auto l_axes = es_loss(EsVariant::kEsD2, out, actions, all_true(1, 1), EsTarget{torch::zeros({1, 3}), {}}, 1.0,
                              kUnused, 0.0, /*per_axis_target=*/true);
  EXPECT_NEAR(l_sum.loss.item<double>(), 0.0, 1e-7);
  EXPECT_NEAR(l_axes.loss.item<double>(), (0.5 + 0.5 + 0.0) / 3.0, 1e-6);  // Huber(1) = Huber(-1) = 0.5
  ASSERT_EQ(l_axes.prediction.sizes(), (std::vector<int64_t>{1, 3}));
  EXPECT_EQ(l_axes.valid.sizes(), l_axes.prediction.sizes());
  EXPECT_THROW(es_target(EsVariant::kEsD1, next, reward, done, all_true(t, n_a), next_active, kEps, kGamma, kUnused,
                         EsTargetRule{true}),
               c10::Error);
}

// hl.team_explore_scale (es_d2): an axis drawn per team at scale x eps is valued with that eps.
TEST(EsTarget, TeamAxisEpsilonScale) {
  models::HlOutput next;
  next.q = decoupled_next_q();  // see its comment: per axis max and mean of each aircraft
  const auto reward = torch::tensor({{1.f, 2.f}});
  const auto done = torch::tensor({false});
  EsTargetRule rule;
  rule.axis_epsilon_scale = {1.0, 0.25, 1.0};
  const auto y = es_target(EsVariant::kEsD2, next, reward, done, all_true(1, 2), all_true(1, 2), kEps, kGamma, kUnused, rule);
  // x: (1.9 + 0.95) / 2; y: [1, 1] -> 1 and [0, 0] -> 0 at any eps; z: (3.8 + 2.85) / 2.
  EXPECT_NEAR(y.value[0].item<double>(), 1.5 + kGamma * (1.425 + 0.5 + 3.325) / 3.0, 1e-5);
  auto q = decoupled_next_q();
  q[1][1] = torch::tensor({0.f, 4.f});  // aircraft 1's lateral: max 4, mean 2, so eps matters
  next.q = q;
  const double e = kEps * 0.25;
  const double lateral = (1.0 + ((1.0 - e) * 4.0 + e * 2.0)) / 2.0;
  const auto ys = es_target(EsVariant::kEsD2, next, reward, done, all_true(1, 2), all_true(1, 2), kEps, kGamma, kUnused, rule);
  EXPECT_NEAR(ys.value[0].item<double>(), 1.5 + kGamma * (1.425 + lateral + 3.325) / 3.0, 1e-5);
  // Scale 1 is the paper's target, bit for bit.
  const auto y1 = es_target(EsVariant::kEsD2, next, reward, done, all_true(1, 2), all_true(1, 2), kEps, kGamma, kUnused,
                            EsTargetRule{});
  const auto y_plain = es_target(EsVariant::kEsD2, next, reward, done, all_true(1, 2), all_true(1, 2), kEps, kGamma, kUnused);
  EXPECT_TRUE(torch::equal(y1.value, y_plain.value));
  EXPECT_GT(std::abs(ys.value[0].item<double>() - y_plain.value[0].item<double>()), 1e-3);
  EXPECT_THROW(es_target(EsVariant::kEsD3, next, reward, done, all_true(1, 2), all_true(1, 2), kEps, kGamma, kUnused, rule),
               c10::Error);
}

// hl.lateral: team (es_d2). The lateral axis's next value is the team lane's: eps-greedy over the
// mean of the members' lateral utilities (members alive next), not the mean of each member's own
// eps-greedy value; the other axes keep theirs.
TEST(EsTarget, TeamLateralLaneValue) {
  // decoupled_next_q's lateral utilities: aircraft 0 [1, 1], aircraft 1 [0, 0] -> team mean
  // [0.5, 0.5], lane value 0.5 (as the mean of their own, 1.0 and 0). Put the members at odds:
  // aircraft 0 [3, 0], aircraft 1 [0, 2] -> own values 2.85 and 1.9 (mean 2.375), team mean
  // [1.5, 1] -> 0.9 * 1.5 + 0.1 * 1.25 = 1.475.
  auto q = decoupled_next_q();
  q[0][1] = torch::tensor({3.f, 0.f});
  q[1][1] = torch::tensor({0.f, 2.f});
  models::HlOutput next;
  next.q = q;
  const auto reward = torch::tensor({{1.f, 2.f}});
  const auto done = torch::tensor({false});
  const EsTargetRule lane{false, true}, lane_axes{true, true};
  const auto y = es_target(EsVariant::kEsD2, next, reward, done, all_true(1, 2), all_true(1, 2), kEps, kGamma, kUnused, lane);
  // x: (1.9 + 0.95) / 2, y: 1.475, z: (3.8 + 2.85) / 2
  const double x = 1.425, lateral = 1.475, z = 3.325;
  EXPECT_NEAR(y.value[0].item<double>(), 1.5 + kGamma * (x + lateral + z) / 3.0, 1e-5);
  const auto own = es_target(EsVariant::kEsD2, next, reward, done, all_true(1, 2), all_true(1, 2), kEps, kGamma, kUnused);
  EXPECT_NEAR(own.value[0].item<double>(), 1.5 + kGamma * (x + 2.375 + z) / 3.0, 1e-5);  // the paper's: lower by 0.15
  const auto ya = es_target(EsVariant::kEsD2, next, reward, done, all_true(1, 2), all_true(1, 2), kEps, kGamma, kUnused,
                            lane_axes);
  ASSERT_EQ(ya.value.sizes(), (std::vector<int64_t>{1, 3}));
  EXPECT_NEAR(ya.value[0][1].item<double>(), 1.5 + kGamma * lateral, 1e-5);
  EXPECT_NEAR(ya.value[0][0].item<double>(), 1.5 + kGamma * x, 1e-5);
  // A member dead next leaves the lane to the other: aircraft 0 alone, 0.9 * 3 + 0.1 * 1.5.
  const auto solo = es_target(EsVariant::kEsD2, next, reward, done, all_true(1, 2), torch::tensor({{true, false}}), kEps,
                              kGamma, kUnused, lane_axes);
  EXPECT_NEAR(solo.value[0][1].item<double>(), 1.5 + kGamma * 2.85, 1e-5);
  // A team of one has no one to agree with: the lane is its own value.
  models::HlOutput one;
  one.q = q.narrow(0, 0, 1);
  const auto y1 = es_target(EsVariant::kEsD2, one, torch::tensor({{1.f}}), done, all_true(1, 1), all_true(1, 1), kEps,
                            kGamma, kUnused, lane);
  const auto y1_own = es_target(EsVariant::kEsD2, one, torch::tensor({{1.f}}), done, all_true(1, 1), all_true(1, 1),
                                kEps, kGamma, kUnused);
  EXPECT_NEAR(y1.value[0].item<double>(), y1_own.value[0].item<double>(), 1e-6);
  EXPECT_THROW(es_target(EsVariant::kEsD3, next, reward, done, all_true(1, 2), all_true(1, 2), kEps, kGamma, kUnused, lane),
               c10::Error);
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

// hl.explore: team. Rows of one group (a team's aircraft) share the exploration coin and the
// random bin per axis; each row's marginal policy stays eps-greedy with the same eps, which the
// ES targets assume.
TEST(EsExploration, TeamGroupsShareTheirDrawsAndKeepTheMarginals) {
  torch::manual_seed(3);
  EsConfig cfg;
  cfg.variant = EsVariant::kEsD2;
  cfg.dims = models::ObsDims{4, 2, 2, 1};
  cfg.d_model = 8;
  cfg.n_heads = 2;
  cfg.hidden = {16, 16};
  cfg.explore_per_team = {true, true, true};
  EsAgent agent(cfg);
  const int64_t b = 6000, team = 3;
  auto input_gen = models::make_generator(9);
  const models::HlObs obs{torch::randn({b, 4}, input_gen), torch::zeros({b, 3}), torch::randn({b, 1, 2}, input_gen),
                          torch::ones({b, 1}, torch::kBool), torch::randn({b, 2}, input_gen)};
  // Group ids as the trainer makes them (aircraft / team size), with gaps: ids 0, 0, 0, 2, 2, 2, ...
  const auto group = torch::arange(b, torch::kInt64).div(team, "floor") * 2;
  auto gen = models::make_generator(4);
  const EsAction greedy = agent.act(obs, 0.0, gen, group);
  EXPECT_TRUE(greedy.bins.equal(greedy.greedy_bins));
  const auto by_team = [&](const torch::Tensor& bins) { return bins.view({b / team, team, 3}); };
  {  // eps 1: every axis explores, one bin per team and axis
    const auto bins = by_team(agent.act(obs, 1.0, gen, group).bins);
    EXPECT_TRUE(bins.eq(bins.select(1, 0).unsqueeze(1)).all().item<bool>());
    const auto count = torch::bincount(bins.select(1, 0).reshape({-1}), {}, 7).to(torch::kFloat64);
    const double expected = static_cast<double>(b / team * 3) / 7.0;
    EXPECT_LT(((count - expected).pow(2) / expected).sum().item<double>(), 22.46);  // chi2, 6 dof, 0.999
  }
  {  // eps 0.3: off the greedy bin with probability 0.3 * 6/7 per row and axis; within a team an
     // axis either explores for all (one shared bin) or for none (each row greedy)
    const EsAction a = agent.act(obs, 0.3, gen, group);
    const auto off = a.bins.ne(a.greedy_bins);
    EXPECT_NEAR(off.to(torch::kFloat64).mean().item<double>(), 0.3 * 6.0 / 7.0, 0.03);
    const auto bins = by_team(a.bins), any_off = by_team(off).any(1);  // [teams, 3]
    const auto shared = bins.eq(bins.select(1, 0).unsqueeze(1)).all(1);
    EXPECT_TRUE(shared.logical_or(any_off.logical_not()).all().item<bool>());
    // Without groups the rows of a team explore apart: shared bins on exploring axes are rare.
    const EsAction solo = agent.act(obs, 1.0, gen);
    EXPECT_LT(by_team(solo.bins).eq(by_team(solo.bins).select(1, 0).unsqueeze(1)).all(1).to(torch::kFloat64)
                  .mean().item<double>(),
              0.1);
  }
  EXPECT_THROW(agent.act(obs, 0.1, gen, group.flip(0)), c10::Error);  // ids must not decrease
  // team_y: only the second axis is drawn per team; the others per aircraft.
  cfg.explore_per_team = {false, true, false};
  torch::manual_seed(3);
  EsAgent lateral(cfg);
  const auto bins = by_team(lateral.act(obs, 1.0, gen, group).bins);
  const auto shared = bins.eq(bins.select(1, 0).unsqueeze(1)).all(1).to(torch::kFloat64).mean(0);  // [3]
  EXPECT_EQ(shared[1].item<double>(), 1.0);
  EXPECT_LT(shared[0].item<double>(), 0.1);  // three independent uniform bins agree 1 / 49 of the time
  EXPECT_LT(shared[2].item<double>(), 0.1);
  const EsAction some = lateral.act(obs, 0.3, gen, group);
  EXPECT_NEAR(some.bins.ne(some.greedy_bins).to(torch::kFloat64).mean().item<double>(), 0.3 * 6.0 / 7.0, 0.03);

  // hl.lateral: team: one lane per team, the argmax of the members' summed lateral utilities,
  // explored per team; the other axes stay each aircraft's own.
  cfg.explore_per_team = {false, false, false};
  cfg.team_lateral = true;
  torch::manual_seed(3);
  EsAgent lane(cfg);
  const EsAction g = lane.act(obs, 0.0, gen, group);
  const auto team_sum = g.q.select(1, 1).view({b / team, team, 7}).sum(1);  // [teams, 7]
  EXPECT_TRUE(by_team(g.greedy_bins).select(2, 1).eq(team_sum.argmax(1).unsqueeze(1)).all().item<bool>());
  EXPECT_TRUE(g.greedy_bins.select(1, 0).equal(g.q.select(1, 0).argmax(1)));
  EXPECT_TRUE(g.greedy_bins.select(1, 2).equal(g.q.select(1, 2).argmax(1)));
  // Members disagree on their own argmax often enough for the lane to matter in this check.
  const auto own_y = by_team(g.q.argmax(2)).select(2, 1);
  EXPECT_GT(own_y.ne(own_y.select(1, 0).unsqueeze(1)).any(1).to(torch::kFloat64).mean().item<double>(), 0.1);
  const auto explored = by_team(lane.act(obs, 1.0, gen, group).bins);
  EXPECT_TRUE(explored.select(2, 1).eq(explored.select(2, 1).select(1, 0).unsqueeze(1)).all().item<bool>());
  EXPECT_THROW(lane.act(obs, 0.0, gen), c10::Error);  // the lane needs the teams
  cfg.variant = EsVariant::kEsD3;
  EXPECT_THROW(EsAgent{cfg}, c10::Error);

  // hl.team_explore_scale: a team axis's coin at scale x eps; the row axes keep eps.
  cfg.variant = EsVariant::kEsD2;
  cfg.team_lateral = false;
  cfg.explore_per_team = {false, true, false};
  cfg.team_explore_scale = 0.25;
  torch::manual_seed(3);
  EsAgent quarter(cfg);
  const EsAction qa = quarter.act(obs, 0.8, gen, group);
  const auto off = qa.bins.ne(qa.greedy_bins).to(torch::kFloat64).mean(0);  // [3]
  EXPECT_NEAR(off[1].item<double>(), 0.2 * 6.0 / 7.0, 0.03);  // 2000 teams: sd 0.009
  EXPECT_NEAR(off[0].item<double>(), 0.8 * 6.0 / 7.0, 0.03);
  EXPECT_EQ(es_target_rule(cfg).axis_epsilon_scale, (std::array<double, 3>{1.0, 0.25, 1.0}));
  cfg.team_explore_scale = 0.0;
  EXPECT_THROW(EsAgent{cfg}, c10::Error);
}

}  // namespace
}  // namespace f16race::agents
