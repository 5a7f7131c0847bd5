// The Eigen forward pass of the low-level actor-critic and of the high-level critic is held equal
// to the LibTorch one: random weights (biases too), random observations with some aircraft dead
// and some samples with nobody alive, several batch sizes, several network shapes.
#include <gtest/gtest.h>
#include <omp.h>
#include <torch/torch.h>

#include <algorithm>
#include <cmath>
#include <stdexcept>
#include <string>

#include "models/kernels/attention_mlp_forward.hpp"
#include "models/hl_critic.hpp"
#include "models/ll_actor_critic.hpp"
#include "models/obs.hpp"

namespace f16race::models {
namespace {

LlObs random_obs(at::Generator& g, const ObsDims& d, int64_t b) {
  LlObs o{torch::randn({b, d.d_ego}, g), torch::randn({b, d.d_goal}, g), torch::randn({b, d.n_other, d.d_ado}, g),
          torch::rand({b, d.n_other}, g) < 0.6, torch::randn({b, d.d_task}, g)};
  if (b > 2) o.ado_alive[1].fill_(false);  // nobody alive: the encoder gives exact zeros
  return o;
}

void randomize(torch::nn::Module& net, at::Generator& g) {
  torch::NoGradGuard no_grad;
  for (auto& p : net.parameters()) p.copy_(0.3 * torch::randn(p.sizes(), g));
}

TEST(AttentionMlpForward, EqualsTheLibTorchForwardToFloatRounding) {
  at::Generator g = make_generator(11);
  for (const auto& [hidden, heads] : {std::pair{std::vector<int64_t>{64, 64}, 4}, {std::vector<int64_t>{32, 16, 8}, 2}}) {
    LlActorCriticConfig cfg;
    cfg.dims = ObsDims{22, 8, 24, 7};
    cfg.hidden = hidden;
    cfg.n_heads = heads;
    cfg.d_model = 16 * heads;
    LlActorCritic net(cfg);
    randomize(*net, g);
    AttentionMlpForward fast;
    fast.set_weights(net->eigen_weights());
    for (int64_t b : {1, 5, 256, 1000}) {
      const LlObs obs = random_obs(g, cfg.dims, b);
      torch::NoGradGuard no_grad;
      const LlOutput want = net(obs);
      auto mean = torch::empty({b, 3}), value = torch::empty({b});
      fast.forward(b, obs.ego.data_ptr<float>(), obs.goal.data_ptr<float>(), obs.ado.data_ptr<float>(),
                   obs.ado_alive.data_ptr<bool>(), obs.task.data_ptr<float>(), mean.data_ptr<float>(),
                   value.data_ptr<float>());
      // Outputs are O(1) here; float rounding in another summation order stays near 1e-6.
      EXPECT_LT((mean - want.mean).abs().max().item<double>(), 2e-5) << "B=" << b;
      EXPECT_LT((value - want.value).abs().max().item<double>(), 2e-5) << "B=" << b;
      EXPECT_GT(want.mean.abs().max().item<double>(), 0.1);  // not a vacuous comparison of zeros
    }
  }
}

// The HL critic (ReLU trunk and head, no value MLP) through the same kernels, q from the heads'
// output by HlCritic::from_head: the joint (es), decoupled (es_d1/es_d2) and C51 (es_d3) heads,
// at 1 and 2 threads.
TEST(AttentionMlpForward, HlCriticEqualsTheLibTorchForwardToFloatRounding) {
  at::Generator g = make_generator(13);
  const int threads = omp_get_max_threads();
  for (const auto& [decoupled, atoms] : {std::pair{false, int64_t{1}}, {true, int64_t{1}}, {true, int64_t{51}}}) {
    HlCriticConfig cfg;
    cfg.dims = ObsDims{22, 3, 24, 7};
    cfg.decoupled = decoupled;
    cfg.n_atoms = atoms;
    HlCritic net(cfg);
    randomize(*net, g);
    AttentionMlpForward fast;
    fast.set_weights(net->eigen_weights());
    for (int t : {1, 2}) {
      omp_set_num_threads(t);
      for (int64_t b : {1, 4, 11, 300}) {
        const LlObs o = random_obs(g, cfg.dims, b);
        const HlObs obs{o.ego, o.goal, o.ado, o.ado_alive, o.task};
        torch::NoGradGuard no_grad;
        const HlOutput want = net(obs);
        auto head = torch::empty({b, net->head_width()});
        fast.forward(b, obs.ego.data_ptr<float>(), obs.prev_action.data_ptr<float>(), obs.ado.data_ptr<float>(),
                     obs.ado_alive.data_ptr<bool>(), obs.task.data_ptr<float>(), head.data_ptr<float>(), nullptr);
        const HlOutput got = net->from_head(head);
        ASSERT_EQ(got.q.sizes(), want.q.sizes());
        const std::string at = "decoupled " + std::to_string(decoupled) + " atoms " + std::to_string(atoms) +
                               " B " + std::to_string(b) + " threads " + std::to_string(t);
        // ReLU keeps these random weights' outputs at O(10-100): float rounding relative to the
        // heads' output, ~1e-6 per layer. log_softmax moves by at most twice the logits' error, and
        // a C51 mean sum_k z_k p_k by at most max|z| times the probabilities' summed change.
        const double head_scale = head.abs().max().item<double>(), tol = 1e-5 * head_scale;
        EXPECT_GT(want.q.abs().max().item<double>(), 0.1) << at;  // not a vacuous comparison of zeros
        if (atoms == 1) {
          EXPECT_LT((got.q - want.q).abs().max().item<double>(), tol) << at << ", |head| " << head_scale;
        } else {
          const double z_max = std::max(std::abs(cfg.v_min), std::abs(cfg.v_max));
          EXPECT_LT((got.log_probs - want.log_probs).abs().max().item<double>(), 2 * tol) << at;
          EXPECT_LT((got.q - want.q).abs().max().item<double>(), z_max * 4 * tol) << at << ", |head| " << head_scale;
        }
      }
    }
  }
  omp_set_num_threads(threads);
}

// Rows go in fixed blocks over the OpenMP threads: the same bits at 1 and 2 threads.
TEST(AttentionMlpForward, SameBitsAtAnyThreadCount) {
  at::Generator g = make_generator(12);
  LlActorCriticConfig cfg;
  cfg.dims = ObsDims{22, 8, 24, 7};
  LlActorCritic net(cfg);
  randomize(*net, g);
  AttentionMlpForward fast;
  fast.set_weights(net->eigen_weights());
  const int64_t b = 777;  // 12 full blocks and a partial one
  const LlObs obs = random_obs(g, cfg.dims, b);
  torch::Tensor means[2], values[2];
  const int threads = omp_get_max_threads();
  for (int t : {1, 2}) {
    omp_set_num_threads(t);
    means[t - 1] = torch::empty({b, 3});
    values[t - 1] = torch::empty({b});
    fast.forward(b, obs.ego.data_ptr<float>(), obs.goal.data_ptr<float>(), obs.ado.data_ptr<float>(),
                 obs.ado_alive.data_ptr<bool>(), obs.task.data_ptr<float>(), means[t - 1].data_ptr<float>(),
                 values[t - 1].data_ptr<float>());
  }
  omp_set_num_threads(threads);
  EXPECT_TRUE(torch::equal(means[0], means[1]));
  EXPECT_TRUE(torch::equal(values[0], values[1]));
}

// The draw done in the forward's blocks is PpoAgent::act's torch ops, bit for bit: action =
// mean + noise * exp(log_std) and gaussian_log_prob, for several log_std, batch sizes and 1 and
// 2 threads (the rollout's samples, and so every PPO update, must not change with the path).
TEST(AttentionMlpForward, DrawInTheBlocksIsTheTorchOpsBitForBit) {
  at::Generator g = make_generator(13);
  LlActorCriticConfig cfg;
  cfg.dims = ObsDims{22, 8, 24, 7};
  cfg.action_dim = 4;
  LlActorCritic net(cfg);
  randomize(*net, g);
  AttentionMlpForward fast;
  fast.set_weights(net->eigen_weights());
  for (const double scale : {0.0, 0.7, 2.5}) {
    const auto log_std = (scale * torch::randn({4}, g) - 1.0).to(torch::kFloat32).contiguous();
    const auto std_dev = log_std.exp(), inv_std = (-log_std).exp();
    for (int64_t b : {1, 7, 66, 300}) {
      for (int threads : {1, 2}) {
        omp_set_num_threads(threads);
        const LlObs obs = random_obs(g, cfg.dims, b);
        const auto noise = torch::randn({b, 4}, g);
        auto mean = torch::empty({b, 4}), value = torch::empty({b});
        auto action = torch::empty({b, 4}), log_prob = torch::empty({b});
        GaussianDraw draw;
        draw.noise = noise.data_ptr<float>();
        draw.std = std_dev.data_ptr<float>();
        draw.inv_std = inv_std.data_ptr<float>();
        draw.log_std = log_std.data_ptr<float>();
        draw.action = action.data_ptr<float>();
        draw.log_prob = log_prob.data_ptr<float>();
        fast.forward(b, obs.ego.data_ptr<float>(), obs.goal.data_ptr<float>(), obs.ado.data_ptr<float>(),
                     obs.ado_alive.data_ptr<bool>(), obs.task.data_ptr<float>(), mean.data_ptr<float>(),
                     value.data_ptr<float>(), &draw);
        // PpoAgent::act's ops before the draw moved into the blocks.
        const auto expanded = log_std.expand_as(mean);
        const auto want_action = mean + noise * expanded.exp();
        const auto want_log_prob = gaussian_log_prob(mean, expanded, want_action);
        EXPECT_TRUE(torch::equal(action, want_action)) << "B=" << b << " threads=" << threads;
        EXPECT_TRUE(torch::equal(log_prob, want_log_prob))
            << "B=" << b << " threads=" << threads << " max diff "
            << (log_prob - want_log_prob).abs().max().item<double>();
      }
    }
  }
  omp_set_num_threads(2);
}

TEST(AttentionMlpForward, RefusesWeightsThatDoNotChain) {
  LlActorCriticConfig cfg;
  cfg.dims = ObsDims{22, 8, 24, 7};
  LlActorCritic net(cfg);
  AttentionMlpWeights w = net->eigen_weights();
  w.mlp[1].in = 63;  // the action MLP's second layer no longer takes the first one's 64 outputs
  w.mlp[1].weight.resize(64 * 63);
  AttentionMlpForward fast;
  EXPECT_THROW(fast.set_weights(w), std::invalid_argument);
  EXPECT_FALSE(fast.ready());
}

}  // namespace
}  // namespace f16race::models
