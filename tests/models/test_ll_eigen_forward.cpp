// The Eigen forward pass of the low-level actor-critic is held equal to the LibTorch one: random
// weights (biases too), random observations with some aircraft dead and some samples with nobody
// alive, several batch sizes, two network shapes.
#include <gtest/gtest.h>
#include <omp.h>
#include <torch/torch.h>

#include <stdexcept>

#include "models/kernels/ll_eigen_forward.hpp"
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

void randomize(LlActorCriticImpl& net, at::Generator& g) {
  torch::NoGradGuard no_grad;
  for (auto& p : net.parameters()) p.copy_(0.3 * torch::randn(p.sizes(), g));
}

TEST(LlEigenForward, EqualsTheLibTorchForwardToFloatRounding) {
  at::Generator g = make_generator(11);
  for (const auto& [hidden, heads] : {std::pair{std::vector<int64_t>{64, 64}, 4}, {std::vector<int64_t>{32, 16, 8}, 2}}) {
    LlActorCriticConfig cfg;
    cfg.dims = ObsDims{22, 8, 24, 7};
    cfg.hidden = hidden;
    cfg.n_heads = heads;
    cfg.d_model = 16 * heads;
    LlActorCritic net(cfg);
    randomize(*net, g);
    LlEigenForward fast;
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

// Rows go in fixed blocks over the OpenMP threads: the same bits at 1 and 2 threads.
TEST(LlEigenForward, SameBitsAtAnyThreadCount) {
  at::Generator g = make_generator(12);
  LlActorCriticConfig cfg;
  cfg.dims = ObsDims{22, 8, 24, 7};
  LlActorCritic net(cfg);
  randomize(*net, g);
  LlEigenForward fast;
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
TEST(LlEigenForward, DrawInTheBlocksIsTheTorchOpsBitForBit) {
  at::Generator g = make_generator(13);
  LlActorCriticConfig cfg;
  cfg.dims = ObsDims{22, 8, 24, 7};
  cfg.action_dim = 4;
  LlActorCritic net(cfg);
  randomize(*net, g);
  LlEigenForward fast;
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

TEST(LlEigenForward, RefusesWeightsThatDoNotChain) {
  LlActorCriticConfig cfg;
  cfg.dims = ObsDims{22, 8, 24, 7};
  LlActorCritic net(cfg);
  LlEigenWeights w = net->eigen_weights();
  w.actor[1].in = 63;  // the actor's second layer no longer takes the first one's 64 outputs
  w.actor[1].weight.resize(64 * 63);
  LlEigenForward fast;
  EXPECT_THROW(fast.set_weights(w), std::invalid_argument);
  EXPECT_FALSE(fast.ready());
}

}  // namespace
}  // namespace f16race::models
