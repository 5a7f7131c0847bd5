// The Eigen forward pass of the low-level actor-critic is held equal to the LibTorch one: random
// weights (biases too), random observations with some aircraft dead and some samples with nobody
// alive, several batch sizes, two network shapes.
#include <gtest/gtest.h>
#include <omp.h>
#include <torch/torch.h>

#include <cmath>
#include <stdexcept>
#include <vector>

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

// A rollout's env slices run their rows on their own threads (forward_on_thread): a row's bits
// must not depend on which rows share its 32-row block, or the slices would change the run.
TEST(LlEigenForward, SlicesOnTheirOwnThreadsGiveTheBitsOfOneCall) {
  at::Generator g = make_generator(13);
  LlActorCriticConfig cfg;
  cfg.dims = ObsDims{22, 8, 24, 7};
  LlActorCritic net(cfg);
  randomize(*net, g);
  LlEigenForward fast;
  fast.set_weights(net->eigen_weights());
  const int64_t b = 777;
  const LlObs obs = random_obs(g, cfg.dims, b);
  auto mean = torch::empty({b, 3}), value = torch::empty({b});
  fast.forward(b, obs.ego.data_ptr<float>(), obs.goal.data_ptr<float>(), obs.ado.data_ptr<float>(),
               obs.ado_alive.data_ptr<bool>(), obs.task.data_ptr<float>(), mean.data_ptr<float>(), value.data_ptr<float>());
  const std::vector<int64_t> cuts{0, 1, 45, 46, 200, 233, 640, 777};  // no cut on a block boundary but 0
  const int n_slices = static_cast<int>(cuts.size()) - 1;
  fast.reserve_slots(n_slices);
  auto mean_s = torch::full({b, 3}, std::nanf("")), value_s = torch::full({b}, std::nanf(""));
#pragma omp parallel for num_threads(2) schedule(static)
  for (int k = 0; k < n_slices; ++k) {
    const int64_t lo = cuts[k], n = cuts[k + 1] - lo;
    fast.forward_on_thread(k, n, obs.ego.data_ptr<float>() + lo * cfg.dims.d_ego,
                           obs.goal.data_ptr<float>() + lo * cfg.dims.d_goal,
                           obs.ado.data_ptr<float>() + lo * cfg.dims.n_other * cfg.dims.d_ado,
                           obs.ado_alive.data_ptr<bool>() + lo * cfg.dims.n_other,
                           obs.task.data_ptr<float>() + lo * cfg.dims.d_task, mean_s.data_ptr<float>() + lo * 3,
                           value_s.data_ptr<float>() + lo);
  }
  EXPECT_TRUE(torch::equal(mean_s, mean));
  EXPECT_TRUE(torch::equal(value_s, value));
}

}  // namespace
}  // namespace f16race::models
