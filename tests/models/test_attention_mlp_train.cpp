// The low level's fused training pass (models/kernels/attention_mlp_train.hpp) is held to LibTorch's
// autograd through LlActorCritic::forward, the oracle: outputs and every weight's and bias's
// gradient, random weights and observations with dead aircraft and a sample with nobody alive,
// rows gathered with repeats, two network shapes. Its outputs are the rollout forward's bits.
#include <gtest/gtest.h>
#include <torch/torch.h>

#include <algorithm>
#include <stdexcept>
#include <string>
#include <vector>

#include "models/kernels/attention_mlp_forward.hpp"
#include "models/kernels/attention_mlp_train.hpp"
#include "models/hl_critic.hpp"
#include "models/ll_actor_critic.hpp"
#include "models/obs.hpp"

namespace f16race::models {
namespace {

constexpr int64_t kBufferRows = 300;  // the buffer the chunks gather from

LlObs buffer_obs(at::Generator& g, const ObsDims& d, int64_t b) {
  LlObs o{torch::randn({b, d.d_ego}, g), torch::randn({b, d.d_goal}, g), torch::randn({b, d.n_other, d.d_ado}, g),
          torch::rand({b, d.n_other}, g) < 0.6, torch::randn({b, d.d_task}, g)};
  o.ado_alive[1].fill_(false);  // nobody alive: the encoder gives exact zeros
  return o;
}

LlActorCritic random_ll_net(at::Generator& g, const std::vector<int64_t>& hidden, int64_t heads) {
  LlActorCriticConfig cfg;
  cfg.dims = ObsDims{22, 8, 7, 5};
  cfg.hidden = hidden;
  cfg.n_heads = heads;
  cfg.d_model = 16 * heads;
  LlActorCritic net(cfg);
  torch::NoGradGuard no_grad;
  for (auto& p : net->parameters()) p.copy_(0.3 * torch::randn(p.sizes(), g));
  return net;
}

kernels::TrainRows train_rows_of(const LlObs& o, const torch::Tensor& index) {
  kernels::TrainRows r;
  r.ego = o.ego.data_ptr<float>(), r.goal = o.goal.data_ptr<float>(), r.ado = o.ado.data_ptr<float>();
  r.ado_alive = o.ado_alive.data_ptr<bool>(), r.task = o.task.data_ptr<float>();
  r.index = index.data_ptr<int64_t>();
  return r;
}

double largest_abs(const torch::Tensor& t) { return t.abs().max().item<double>(); }

TEST(AttentionMlpTrain, EqualsLibTorchAutogradInOutputsAndGradients) {
  at::Generator g = make_generator(21);
  for (const auto& [hidden, heads] : {std::pair{std::vector<int64_t>{64, 64}, 4}, {std::vector<int64_t>{32, 16, 8}, 2}}) {
    LlActorCritic net = random_ll_net(g, hidden, heads);
    const LlObs buffer = buffer_obs(g, net->config().dims, kBufferRows);
    kernels::AttentionMlpTrain pass;
    for (int64_t b : {200, 1, 7}) {  // the large chunk first: the scratch is reused by the smaller
      auto index = torch::randint(0, kBufferRows, {b}, g, torch::kInt64);
      index[0] = 1;  // the sample with nobody alive is in every chunk
      auto mean = torch::empty({b, 3}), value = torch::empty({b});
      const auto view = net->train_net();
      pass.forward(view, b, train_rows_of(buffer, index), mean.data_ptr<float>(), value.data_ptr<float>());
      const auto d_mean = torch::randn({b, 3}, g), d_value = torch::randn({b}, g);
      const std::vector<torch::Tensor> params = net->parameters();
      std::vector<torch::Tensor> grads;
      for (const auto& p : params) grads.push_back(torch::full_like(p, 7.0f));  // overwritten, not added to
      pass.backward(view, d_mean.data_ptr<float>(), d_value.data_ptr<float>(), net->train_grads(grads));

      const LlOutput want = net(index_rows(buffer, index));
      EXPECT_LT(largest_abs(mean - want.mean.detach()), 2e-5) << "B=" << b;
      EXPECT_LT(largest_abs(value - want.value.detach()), 2e-5) << "B=" << b;
      const auto loss = (want.mean * d_mean).sum() + (want.value * d_value).sum();
      const auto oracle = torch::autograd::grad({loss}, params, {}, false, false, /*allow_unused=*/true);
      for (std::size_t i = 0; i < params.size(); ++i) {
        if (params[i].is_same(net->log_std())) {  // the loss's, not the network's: left as it was
          EXPECT_TRUE(grads[i].eq(7.0f).all().item<bool>());
          continue;
        }
        ASSERT_TRUE(oracle[i].defined()) << i;
        const double scale = 1.0 + largest_abs(oracle[i]);
        EXPECT_LT(largest_abs(grads[i] - oracle[i]), 2e-5 * scale) << "parameter " << i << " at B=" << b;
        // Not a comparison of zeros, but for the key bias: it shifts every score of a head by the
        // same q.b, which the softmax cancels, so its gradient is 0 up to rounding.
        const std::string name = net->named_parameters().keys()[i];
        if (b == 200 && name != "encoder.k_proj.bias") {
          EXPECT_GT(largest_abs(oracle[i]), 1e-3) << name;
        }
      }
    }
  }
}

TEST(AttentionMlpTrain, OutputsAreTheRolloutForwardsBits) {
  // The rollout forward (attention_mlp_forward) and the update's forward share products, attention
  // and tanh: PPO's first ratio of an update is exactly 1.
  at::Generator g = make_generator(22);
  LlActorCritic net = random_ll_net(g, {64, 64}, 4);
  const LlObs buffer = buffer_obs(g, net->config().dims, kBufferRows);
  const auto index = torch::randperm(kBufferRows, g, torch::kInt64).slice(0, 0, 150).contiguous();
  auto mean = torch::empty({150, 3}), value = torch::empty({150});
  kernels::AttentionMlpTrain pass;
  pass.forward(net->train_net(), 150, train_rows_of(buffer, index), mean.data_ptr<float>(), value.data_ptr<float>());
  const LlObs rows = index_rows(buffer, index);
  AttentionMlpForward rollout;
  rollout.set_weights(net->eigen_weights());
  auto r_mean = torch::empty({150, 3}), r_value = torch::empty({150});
  rollout.forward(150, rows.ego.data_ptr<float>(), rows.goal.data_ptr<float>(), rows.ado.data_ptr<float>(),
                  rows.ado_alive.data_ptr<bool>(), rows.task.data_ptr<float>(), r_mean.data_ptr<float>(),
                  r_value.data_ptr<float>());
  EXPECT_TRUE(mean.equal(r_mean));
  EXPECT_TRUE(value.equal(r_value));
}

// The HL critic's head logits [B, head_width()] composed of its modules' LibTorch forwards (the
// trunk's own Linear and ReLU): the oracle of the pass's output, for autograd.
torch::Tensor head_logits_oracle(HlCritic& net, const HlObs& o) {
  const auto children = net->named_children();
  auto* encoder = children["encoder"]->as<AttentionEncoderImpl>();
  auto* trunk = children["trunk"]->as<torch::nn::SequentialImpl>();
  auto* head = children["head"]->as<torch::nn::LinearImpl>();
  const auto encoded = encoder->forward(o.ego, o.ado, o.ado_alive);
  return head->forward(trunk->forward(torch::cat({o.ego, o.prev_action, encoded, o.task}, 1)));
}

TEST(AttentionMlpTrain, TheHlCriticsReluTrunkAndHeadEqualAutogradAndTheRolloutForward) {
  at::Generator g = make_generator(24);
  HlCriticConfig cfg;
  cfg.dims = ObsDims{22, 8, 7, 5};
  cfg.n_atoms = 11;
  cfg.v_min = -3.0;
  cfg.v_max = 3.0;
  HlCritic net(cfg);
  {
    torch::NoGradGuard no_grad;
    for (auto& p : net->parameters()) p.copy_(0.3 * torch::randn(p.sizes(), g));
  }
  const LlObs ll = buffer_obs(g, cfg.dims, kBufferRows);  // its goal rows stand for the previous action
  const HlObs buffer{ll.ego, ll.goal, ll.ado, ll.ado_alive, ll.task};
  const int64_t b = 120, w = net->head_width();
  auto index = torch::randint(0, kBufferRows, {b}, g, torch::kInt64);
  index[0] = 1;
  auto head = torch::empty({b, w});
  kernels::AttentionMlpTrain pass;
  const auto view = net->train_net();
  pass.forward(view, b, train_rows_of(ll, index), head.data_ptr<float>(), nullptr);
  const HlObs rows = index_rows(buffer, index);
  AttentionMlpForward rollout;
  rollout.set_weights(net->eigen_weights());
  auto r_head = torch::empty({b, w});
  rollout.forward(b, rows.ego.data_ptr<float>(), rows.prev_action.data_ptr<float>(), rows.ado.data_ptr<float>(),
                  rows.ado_alive.data_ptr<bool>(), rows.task.data_ptr<float>(), r_head.data_ptr<float>(), nullptr);
  EXPECT_TRUE(head.equal(r_head));
  const auto d_head = torch::randn({b, w}, g);
  std::vector<torch::Tensor> grads;
  const std::vector<torch::Tensor> params = net->parameters();
  for (const auto& p : params) grads.push_back(torch::empty_like(p));
  pass.backward(view, d_head.data_ptr<float>(), nullptr, net->train_grads(grads));
  const auto x = head_logits_oracle(net, rows);
  EXPECT_LT(largest_abs(x.detach() - head), 2e-5);
  const auto oracle = torch::autograd::grad({(x * d_head).sum()}, params, {}, false, false, true);
  double largest = 0.0;
  for (const auto& o : oracle) largest = std::max(largest, largest_abs(o));
  for (std::size_t i = 0; i < params.size(); ++i) {
    const std::string name = net->named_parameters().keys()[i];
    if (name == "encoder.k_proj.bias") {  // 0 but for rounding, on both sides: held to the largest's scale
      EXPECT_LT(largest_abs(grads[i] - oracle[i]), 1e-6 * largest) << name;
      continue;
    }
    EXPECT_LT(largest_abs(grads[i] - oracle[i]), 2e-5 * (1.0 + largest_abs(oracle[i]))) << name;
    EXPECT_GT(largest_abs(oracle[i]), 1e-3) << name;
  }
}

TEST(AttentionMlpTrain, RefusesLayersThatDoNotChain) {
  at::Generator g = make_generator(23);
  LlActorCritic net = random_ll_net(g, {64, 64}, 4);
  auto view = net->train_net();
  view.actor[1].in = 63;
  EXPECT_THROW(kernels::AttentionMlpTrain::check(view), std::invalid_argument);
  view = net->train_net();
  view.critic.back().out = 2;
  EXPECT_THROW(kernels::AttentionMlpTrain::check(view), std::invalid_argument);
  EXPECT_NO_THROW(kernels::AttentionMlpTrain::check(net->train_net()));
}

}  // namespace
}  // namespace f16race::models
