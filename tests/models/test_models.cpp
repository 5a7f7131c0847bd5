// Networks: shapes and shape checks, the attention encoder's permutation invariance and
// masking, the distributional head, Gaussian helpers, running normalisation, save/load.
#include <gtest/gtest.h>
#include <omp.h>
#include <torch/torch.h>

#include <cmath>
#include <cstdio>
#include <functional>
#include <string>

#include "models/attention_encoder.hpp"
#include "models/hl_critic.hpp"
#include "models/ll_actor_critic.hpp"
#include "models/obs.hpp"
#include "models/running_norm.hpp"

namespace f16race::models {
namespace {

// Stand-in sizes of the race environment (it defines the real ones).
ObsDims stand_in_dims() { return ObsDims{22, 8, 24, 7}; }

struct Rng {
  at::Generator gen;
  explicit Rng(uint64_t seed) : gen(make_generator(seed)) {}
  torch::Tensor normal(at::IntArrayRef shape) { return torch::randn(shape, gen, torch::kFloat32); }
  torch::Tensor alive(at::IntArrayRef shape, double p) { return torch::rand(shape, gen) < p; }
};

HlObs random_hl_obs(Rng& r, const ObsDims& d, int64_t b) {
  return {r.normal({b, d.d_ego}), r.normal({b, 3}), r.normal({b, d.n_other, d.d_ado}), r.alive({b, d.n_other}, 0.7),
          r.normal({b, d.d_task})};
}

LlObs random_ll_obs(Rng& r, const ObsDims& d, int64_t b) {
  const auto h = random_hl_obs(r, d, b);
  return {h.ego, h.prev_action, h.ado, h.ado_alive, h.task};
}

double max_abs_diff(const torch::Tensor& a, const torch::Tensor& b) { return (a - b).abs().max().item<double>(); }

AttentionEncoder make_encoder(uint64_t seed) {
  torch::manual_seed(seed);  // parameter initialisation only
  const auto d = stand_in_dims();
  return AttentionEncoder(AttentionEncoderConfig{d.d_ego, d.d_ado, d.n_other, 64, 4});
}

TEST(AttentionEncoder, OutputShapeAndPermutationInvariance) {
  auto enc = make_encoder(1);
  Rng r(2);
  const auto d = stand_in_dims();
  const int64_t b = 64;
  const auto ego = r.normal({b, d.d_ego});
  const auto ado = r.normal({b, d.n_other, d.d_ado});
  const auto alive = r.alive({b, d.n_other}, 0.6);
  const auto out = enc(ego, ado, alive);
  ASSERT_EQ(out.sizes(), (std::vector<int64_t>{b, 64}));
  for (uint64_t trial = 0; trial < 5; ++trial) {
    const auto perm = torch::randperm(d.n_other, r.gen, torch::kInt64);
    const auto out_perm = enc(ego, ado.index_select(1, perm), alive.index_select(1, perm));
    EXPECT_LT(max_abs_diff(out, out_perm), 1e-5) << "trial " << trial;
  }
  // The output does depend on the alive rows (a check that could fail if attention were dead).
  const auto ado_changed = ado + 1.0;
  EXPECT_GT(max_abs_diff(out, enc(ego, ado_changed, alive)), 1e-3);
}

TEST(AttentionEncoder, IgnoresMaskedAircraft) {
  auto enc = make_encoder(3);
  Rng r(4);
  const auto d = stand_in_dims();
  const int64_t b = 32;
  const auto ego = r.normal({b, d.d_ego});
  const auto ado = r.normal({b, d.n_other, d.d_ado});
  const auto alive = r.alive({b, d.n_other}, 0.5);
  // Garbage (large values) in the dead rows must not change anything.
  const auto garbage = torch::where(alive.unsqueeze(-1), ado, 1e6 * r.normal({b, d.n_other, d.d_ado}));
  EXPECT_LT(max_abs_diff(enc(ego, ado, alive), enc(ego, garbage, alive)), 1e-6);
  // Removing a dead row equals keeping it masked: compare with a 1-other encoder on alive row 0
  // is not possible (n_other is fixed), so compare against moving dead rows to the end instead.
  const auto order = torch::argsort(alive.logical_not().to(torch::kInt64), 1, /*descending=*/false);
  const auto gathered_ado = ado.gather(1, order.unsqueeze(-1).expand({b, d.n_other, d.d_ado}));
  const auto gathered_alive = alive.gather(1, order);
  EXPECT_LT(max_abs_diff(enc(ego, ado, alive), enc(ego, gathered_ado, gathered_alive)), 1e-5);
}

TEST(AttentionEncoder, AllDeadRowIsExactlyZeroAndGradientFinite) {
  auto enc = make_encoder(5);
  Rng r(6);
  const auto d = stand_in_dims();
  const int64_t b = 8;
  const auto ego = r.normal({b, d.d_ego}).requires_grad_(true);
  const auto ado = r.normal({b, d.n_other, d.d_ado});
  auto alive = torch::ones({b, d.n_other}, torch::kBool);
  alive[3].fill_(false);
  alive[5].fill_(false);
  const auto out = enc(ego, ado, alive);
  EXPECT_EQ(out[3].abs().max().item<float>(), 0.0f);
  EXPECT_EQ(out[5].abs().max().item<float>(), 0.0f);
  EXPECT_GT(out[0].abs().max().item<float>(), 0.0f);
  EXPECT_FALSE(out.isnan().any().item<bool>());
  // Rows do not interact: row 0 alone gives the same result as inside the batch.
  const auto single = enc(ego.slice(0, 0, 1), ado.slice(0, 0, 1), alive.slice(0, 0, 1));
  EXPECT_LT(max_abs_diff(single[0], out[0]), 1e-5);
  out.pow(2).sum().backward();
  EXPECT_TRUE(torch::isfinite(ego.grad()).all().item<bool>());
  for (const auto& p : enc->parameters()) EXPECT_TRUE(torch::isfinite(p.grad()).all().item<bool>());
}

TEST(AttentionEncoder, ShapeErrorsNameTheTensor) {
  auto enc = make_encoder(7);
  const auto d = stand_in_dims();
  const auto ego = torch::zeros({4, d.d_ego});
  const auto ado = torch::zeros({4, d.n_other, d.d_ado});
  const auto alive = torch::ones({4, d.n_other}, torch::kBool);
  const auto expect_error = [](const std::function<void()>& f, const std::string& name) {
    try {
      f();
      ADD_FAILURE() << "no error for " << name;
    } catch (const c10::Error& e) {
      EXPECT_NE(std::string(e.what()).find("'" + name + "'"), std::string::npos) << e.what();
    }
  };
  expect_error([&] { enc(torch::zeros({4, d.d_ego + 1}), ado, alive); }, "ego");
  expect_error([&] { enc(ego, torch::zeros({4, d.n_other + 1, d.d_ado}), alive); }, "ado");
  expect_error([&] { enc(ego, ado, torch::ones({4, d.n_other})); }, "ado_alive");  // float, not bool
  expect_error([&] { enc(ego, ado, torch::ones({3, d.n_other}, torch::kBool)); }, "ado_alive");
}

// The fused attention node gives the composed LibTorch ops' output and gradients (q, k, v) to
// float rounding: random inputs, some keys dead, some samples with nobody alive, N = 1 and 7,
// 1, 2 and 4 heads, and at 1 and 2 intra-op threads (rows split over threads: same bits).
TEST(AttentionEncoder, FusedAttentionEqualsTheComposedOps) {
  auto g = make_generator(21);
  for (const auto& [n, heads] : {std::pair<int64_t, int64_t>{7, 4}, {1, 2}, {7, 1}}) {
    const int64_t b = 600, d = 16 * heads;
    auto q = torch::randn({b, d}, g), k = torch::randn({b, n, d}, g), v = torch::randn({b, n, d}, g);
    auto alive = torch::rand({b, n}, g) < 0.6;
    alive[3].fill_(false);
    alive[4].fill_(true);
    const auto upstream = torch::randn({b, d}, g);
    std::vector<torch::Tensor> results[2];
    for (int path = 0; path < 2; ++path) {
      auto qi = q.clone().requires_grad_(true), ki = k.clone().requires_grad_(true), vi = v.clone().requires_grad_(true);
      const auto out = path == 0 ? masked_attention(qi, ki, vi, alive, heads)
                                 : masked_attention_reference(qi, ki, vi, alive, heads);
      (out * upstream).sum().backward();
      results[path] = {out, qi.grad(), ki.grad(), vi.grad()};
    }
    const char* names[] = {"output", "grad q", "grad k", "grad v"};
    for (int t = 0; t < 4; ++t) {
      EXPECT_LT((results[0][t] - results[1][t]).abs().max().item<double>(), 2e-5) << names[t] << " N=" << n;
      // Not a comparison of zeros; except that with one key its weight is 1 whatever q and k are.
      if (n > 1 || t == 0 || t == 3)
        EXPECT_GT(results[1][t].abs().max().item<double>(), 0.1) << names[t];
      else
        EXPECT_EQ(results[0][t].abs().max().item<double>(), 0.0) << names[t];
    }
    EXPECT_EQ(results[0][0][3].abs().max().item<double>(), 0.0);  // nobody alive: exact zeros
    EXPECT_EQ(results[0][2][3].abs().max().item<double>(), 0.0);  // and no gradient to dead keys
    const auto dead = alive.logical_not().unsqueeze(-1).expand({b, n, d});
    EXPECT_EQ(results[0][3].masked_select(dead).abs().max().item<double>(), 0.0);
    // Another intra-op thread count splits the rows differently: the same bits.
    const int threads = torch::get_num_threads();
    torch::set_num_threads(threads == 1 ? 2 : 1);
    EXPECT_TRUE(torch::equal(masked_attention(q, k, v, alive, heads), results[0][0].detach()));
    torch::set_num_threads(threads);
  }
}

// A critic config with the library's defaults on the stand-in dims, and b random observations.
struct HlCriticCase {
  HlCriticConfig cfg;
  HlObs obs;
};
HlCriticCase hl_critic_case(std::uint64_t seed, int64_t b) {
  Rng r(seed);
  HlCriticCase c;
  c.cfg.dims = stand_in_dims();
  c.obs = random_hl_obs(r, c.cfg.dims, b);
  return c;
}

TEST(HlCritic, ShapesOfEveryHead) {
  const int64_t b = 16;
  auto [cfg, obs] = hl_critic_case(8, b);
  const auto d = cfg.dims;
  {
    HlCritic net(cfg);  // es_d1 / es_d2: decoupled utilities
    const auto out = net(obs);
    EXPECT_EQ(out.q.sizes(), (std::vector<int64_t>{b, 3, 7}));
    EXPECT_FALSE(out.log_probs.defined());
  }
  {
    cfg.decoupled = false;  // es: joint head
    HlCritic net(cfg);
    EXPECT_EQ(net(obs).q.sizes(), (std::vector<int64_t>{b, 343}));
  }
  {
    cfg.decoupled = true;  // es_d3: C51 per dimension and bin
    cfg.n_atoms = 51;
    cfg.v_min = -5.0;
    cfg.v_max = 15.0;
    HlCritic net(cfg);
    const auto out = net(obs);
    ASSERT_EQ(out.log_probs.sizes(), (std::vector<int64_t>{b, 3, 7, 51}));
    const auto probs = out.log_probs.exp();
    EXPECT_LT(max_abs_diff(probs.sum(-1), torch::ones({b, 3, 7})), 1e-5);
    const auto z = torch::linspace(-5.0, 15.0, 51);
    EXPECT_LT(max_abs_diff(out.q, (probs * z).sum(-1)), 1e-5);
    EXPECT_LT(max_abs_diff(net->atoms(), z), 1e-6);
    // Without q (the fused ES+D3 loss): the same distribution to the bit, no q.
    const auto dist_only = net->forward(obs, /*with_q=*/false);
    EXPECT_FALSE(dist_only.q.defined());
    EXPECT_TRUE(torch::equal(dist_only.log_probs, out.log_probs));
  }
  {
    HlCriticConfig plain = cfg;  // one atom: q is the output, asked for or not
    plain.n_atoms = 1;
    HlCritic net(plain);
    EXPECT_TRUE(torch::equal(net->forward(obs, false).q, net(obs).q));
  }
  HlObs bad = obs;
  bad.prev_action = torch::zeros({b, 2});
  EXPECT_THROW(HlCritic(HlCriticConfig{d})(bad), c10::Error);
}

// The critic keeps the module names every checkpoint was written with (encoder, trunk, head),
// and its parameter count and forward FLOPs are those of one encoder, trunk and head.
TEST(HlCritic, ModuleNamesParametersAndFlops) {
  auto [cfg, obs] = hl_critic_case(18, 4);
  for (int64_t atoms : {1, 11}) {
    cfg.n_atoms = atoms;
    HlCritic net(cfg);
    int64_t encoder = 0, rest = 0;
    for (const auto& kv : net->named_parameters()) {
      const std::string top = kv.key().substr(0, kv.key().find('.'));
      EXPECT_TRUE(top == "encoder" || top == "trunk" || top == "head") << kv.key();
      (top == "encoder" ? encoder : rest) += kv.value().numel();
    }
    const int64_t in = cfg.dims.d_ego + cfg.dims.d_prev_action + cfg.d_model + cfg.dims.d_task;
    const int64_t out = 3 * 7 * atoms;  // decoupled: 3 axes x 7 bins x atoms
    EXPECT_EQ(net->head_width(), out);
    EXPECT_EQ(rest, (in + 1) * 64 + (64 + 1) * 64 + (64 + 1) * out);
    AttentionEncoder alone(AttentionEncoderConfig{cfg.dims.d_ego, cfg.dims.d_ado, cfg.dims.n_other, cfg.d_model,
                                                  cfg.n_heads});
    int64_t alone_params = 0;
    for (const auto& p : alone->parameters()) alone_params += p.numel();
    EXPECT_EQ(encoder, alone_params);
    EXPECT_EQ(net->flops_per_sample(), alone->flops_per_sample() + 2 * (in * 64 + 64 * 64 + 64 * out));
  }
}

TEST(LlActorCritic, ShapesAndGaussianHelpers) {
  const auto d = stand_in_dims();
  Rng r(9);
  LlActorCriticConfig cfg;
  cfg.dims = d;
  cfg.init_log_std = -0.5;
  LlActorCritic net(cfg);
  const int64_t b = 10;
  const auto out = net(random_ll_obs(r, d, b));
  EXPECT_EQ(out.mean.sizes(), (std::vector<int64_t>{b, 3}));
  EXPECT_EQ(out.log_std.sizes(), (std::vector<int64_t>{b, 3}));
  EXPECT_EQ(out.value.sizes(), (std::vector<int64_t>{b}));
  EXPECT_FLOAT_EQ(out.log_std[4][2].item<float>(), -0.5f);
  // Output layer gain 0.01: initial means are small.
  EXPECT_LT(out.mean.abs().max().item<float>(), 0.1f);
  // N(0, 1) in 3 dims at 0: log density -1.5 log(2 pi); entropy 1.5 (1 + log(2 pi)).
  const double log2pi = std::log(2.0 * M_PI);
  EXPECT_NEAR(gaussian_log_prob(torch::zeros({1, 3}), torch::zeros({1, 3}), torch::zeros({1, 3})).item<double>(),
              -1.5 * log2pi, 1e-6);
  // sigma = e^0.5, x - mu = (1, 0, -2): sum of -(x-mu)^2/(2 sigma^2) - 0.5 - 0.5 log(2 pi).
  const double s2 = std::exp(1.0);
  const double expected = -(1.0 + 0.0 + 4.0) / (2.0 * s2) - 3 * 0.5 - 1.5 * log2pi;
  EXPECT_NEAR(gaussian_log_prob(torch::tensor({{1.0f, 2.0f, 3.0f}}), torch::full({1, 3}, 0.5f),
                                torch::tensor({{2.0f, 2.0f, 1.0f}}))
                  .item<double>(),
              expected, 1e-5);
  EXPECT_NEAR(gaussian_entropy(torch::full({1, 3}, 0.5f)).item<double>(), 3 * (0.5 + 0.5 * (1.0 + log2pi)), 1e-5);
}

TEST(Models, FlopsPerSampleMatchHandCounts) {
  // d_ego 5, d_ado 4, d_task 6, 3 others, width 8 (2 heads), one hidden layer of 10, 3 bins.
  const ObsDims d{5, 4, 6, 3};
  // Encoder: query 2*5*8 = 80, keys + values 2*2*3*4*8 = 384, scores 2*3*8 = 48, weighted sum
  // 48, output 2*8*8 = 128.
  const int64_t enc = 80 + 384 + 48 + 48 + 128;
  EXPECT_EQ(AttentionEncoder(AttentionEncoderConfig{5, 4, 3, 8, 2})->flops_per_sample(), enc);
  HlCriticConfig hc;
  hc.dims = d;
  hc.d_model = 8;
  hc.n_heads = 2;
  hc.hidden = {10};
  hc.n_bins = 3;
  // Trunk input 5 + 3 + 8 + 6 = 22: 2*22*10 = 440; heads 2*10*out with out 9 (decoupled),
  // 27 (joint), 9 * 4 atoms.
  EXPECT_EQ(HlCritic(hc)->flops_per_sample(), enc + 440 + 180);
  hc.decoupled = false;
  EXPECT_EQ(HlCritic(hc)->flops_per_sample(), enc + 440 + 540);
  hc.decoupled = true;
  hc.n_atoms = 4;
  EXPECT_EQ(HlCritic(hc)->flops_per_sample(), enc + 440 + 720);
  LlActorCriticConfig lc;
  lc.dims = d;
  lc.d_model = 8;
  lc.n_heads = 2;
  lc.hidden = {10};
  // Actor 440 + 2*10*3, critic 440 + 2*10*1.
  EXPECT_EQ(LlActorCritic(lc)->flops_per_sample(), enc + 500 + 460);
}

TEST(RunningNorm, MatchesStatisticsOfAllDataAndClips) {
  Rng r(10);
  RunningNorm norm(4, /*clip=*/5.0);
  const auto a = 3.0 + 2.0 * r.normal({100, 4});
  const auto b = -1.0 + 0.5 * r.normal({37, 4});
  norm->update(a);
  norm->update(b);
  const auto all = torch::cat({a, b}).to(torch::kFloat64);
  // The 1e-4 prior count (mean 0, var 1) perturbs the result by ~1e-6.
  EXPECT_LT(max_abs_diff(norm->mean(), all.mean(0)), 1e-5);
  EXPECT_LT(max_abs_diff(norm->var(), all.var(0, false)), 1e-5);
  EXPECT_NEAR(norm->count(), 137.0001, 1e-9);
  const auto z = norm->normalize(torch::cat({a, b}));
  EXPECT_LT(z.mean(0).abs().max().item<double>(), 1e-4);
  EXPECT_LT((z.std(0, false) - 1.0).abs().max().item<double>(), 1e-4);
  EXPECT_FLOAT_EQ(norm->normalize(torch::full({1, 4}, 1e6f)).max().item<float>(), 5.0f);
}

TEST(RunningNorm, BigBatchesGiveTheSameBitsAtAnyThreadCount) {
  // 5000 x 9 values: above the size at which statistics and normalisation use the OpenMP threads.
  Rng r(12);
  const auto x = 2.0 + 3.0 * r.normal({5000, 9});
  const auto keep = torch::rand({5000}) > 0.2;
  torch::Tensor mean[2], var[2], z[2];
  const int threads = omp_get_max_threads();
  for (int t : {1, 2}) {
    omp_set_num_threads(t);
    RunningNorm norm(9, /*clip=*/5.0);
    norm->update_rows(x, keep);
    norm->update_rows(x * 0.5, torch::Tensor());
    mean[t - 1] = norm->mean().clone();
    var[t - 1] = norm->var().clone();
    z[t - 1] = norm->normalize_rows(x, keep);
  }
  omp_set_num_threads(threads);
  EXPECT_TRUE(mean[0].equal(mean[1]));
  EXPECT_TRUE(var[0].equal(var[1]));
  EXPECT_TRUE(z[0].equal(z[1]));
  // ...and they are the statistics of the kept rows and the halved batch.
  const auto all = torch::cat({x.index({keep}), x * 0.5}).to(torch::kFloat64);
  EXPECT_LT(max_abs_diff(mean[0], all.mean(0)), 1e-5);
  EXPECT_LT(max_abs_diff(var[0], all.var(0, false)), 1e-4);
  EXPECT_EQ(z[0].index({keep.logical_not()}).abs().max().item<float>(), 0.0f);
}

TEST(ObsNormalizer, AdoStatisticsUseAliveRowsOnly) {
  const auto d = stand_in_dims();
  Rng r(11);
  ObsNormalizer norm(d);
  auto obs = random_hl_obs(r, d, 200);
  obs.ado = obs.ado + 2.0;
  obs.ado = torch::where(obs.ado_alive.unsqueeze(-1), obs.ado, torch::full_like(obs.ado, 1e3));
  const auto out = norm->normalize(obs, true);
  const auto alive_rows = obs.ado.reshape({-1, d.d_ado}).index({obs.ado_alive.reshape({-1})});
  const auto stats = norm->named_buffers();
  EXPECT_LT(max_abs_diff(stats["ado.mean"].to(torch::kFloat32), alive_rows.mean(0)), 1e-4);
  // Dead rows come out as exact zeros, alive ones are standardised.
  EXPECT_EQ(out.ado.index({obs.ado_alive.logical_not()}).abs().max().item<float>(), 0.0f);
  EXPECT_LT(out.ado.index({obs.ado_alive}).mean().abs().item<double>(), 1e-3);
  EXPECT_TRUE(out.ado_alive.equal(obs.ado_alive));
}

template <class Net>
void check_round_trip(Net& a, Net& b) {
  const std::string path = ::testing::TempDir() + "/f16race_model_round_trip.pt";
  torch::serialize::OutputArchive out;
  a->save(out);
  out.save_to(path);
  torch::serialize::InputArchive in;
  in.load_from(path);
  b->load(in);
  std::remove(path.c_str());
  for (const auto& item : a->named_parameters()) EXPECT_TRUE(item.value().equal(b->named_parameters()[item.key()]));
  for (const auto& item : a->named_buffers()) EXPECT_TRUE(item.value().equal(b->named_buffers()[item.key()]));
}

TEST(Obs, CountsAliveOthersPerRowAndOverPickedRows) {
  // [4 rows, 3 others]: 2, 0, 3 and 1 alive.
  const auto alive = torch::tensor({1, 0, 1, 0, 0, 0, 1, 1, 1, 0, 1, 0}, torch::kBool).view({4, 3});
  EXPECT_EQ(alive_per_row(alive), (std::vector<int64_t>{2, 0, 3, 1}));
  EXPECT_EQ(count_alive(alive), 6);
  EXPECT_EQ(count_alive(alive, torch::tensor({2, 2, 3}, torch::kInt64)), 7);  // a row picked twice counts twice
  EXPECT_EQ(count_alive(alive, torch::empty({0}, torch::kInt64)), 0);
  EXPECT_EQ(count_alive(alive.t().contiguous().t()), 6);  // a strided view: read as its values
  EXPECT_THROW(count_alive(alive, torch::tensor({4}, torch::kInt64)), c10::Error);
  EXPECT_THROW(count_alive(alive, torch::tensor({-1}, torch::kInt64)), c10::Error);
  EXPECT_THROW(alive_per_row(alive.to(torch::kFloat32)), c10::Error);
}

TEST(Models, SaveLoadRoundTripGivesIdenticalOutputs) {
  const auto d = stand_in_dims();
  Rng r(12);
  const auto hl_obs = random_hl_obs(r, d, 20);
  const auto ll_obs = random_ll_obs(r, d, 20);
  HlCriticConfig hc;
  hc.dims = d;
  hc.n_atoms = 51;
  torch::manual_seed(1);
  HlCritic h1(hc);
  torch::manual_seed(2);
  HlCritic h2(hc);
  EXPECT_GT(max_abs_diff(h1(hl_obs).q, h2(hl_obs).q), 1e-4);  // different before loading
  check_round_trip(h1, h2);
  EXPECT_TRUE(h1(hl_obs).log_probs.equal(h2(hl_obs).log_probs));

  LlActorCriticConfig lc;
  lc.dims = d;
  torch::manual_seed(3);
  LlActorCritic l1(lc);
  torch::manual_seed(4);
  LlActorCritic l2(lc);
  {
    torch::NoGradGuard g;
    l1->named_parameters()["log_std"].fill_(-0.3);
  }
  check_round_trip(l1, l2);
  const auto o1 = l1(ll_obs), o2 = l2(ll_obs);
  EXPECT_TRUE(o1.mean.equal(o2.mean));
  EXPECT_TRUE(o1.value.equal(o2.value));
  EXPECT_TRUE(o1.log_std.equal(o2.log_std));

  ObsNormalizer n1(d), n2(d);
  n1->normalize(ll_obs, true);
  check_round_trip(n1, n2);
  EXPECT_TRUE(n1->normalize(ll_obs, false).ego.equal(n2->normalize(ll_obs, false).ego));
}

}  // namespace
}  // namespace f16race::models
