#include "bench/network_cost.hpp"

#include <algorithm>
#include <functional>
#include <vector>

namespace f16race::bench {

models::HlObs random_hl_obs(const models::ObsDims& dims, std::int64_t b, at::Generator& gen, double alive_share) {
  const auto normal = [&](std::vector<int64_t> s) { return torch::randn(s, gen, torch::kFloat32); };
  return models::HlObs{normal({b, dims.d_ego}), normal({b, 3}), normal({b, dims.n_other, dims.d_ado}),
                       torch::rand({b, dims.n_other}, gen) < alive_share, normal({b, dims.d_task})};
}

namespace {

// Per-sample seconds of forward and forward+backward of `loss_of` at batch b.
template <class Net, class Obs>
SampleCost measure_cost(Net& net, const Obs& obs, const std::function<torch::Tensor(Net&, const Obs&)>& loss_of,
                        std::int64_t b, int repeats) {
  const std::int64_t calls = std::max<std::int64_t>(1, 8192 / b);
  SampleCost c;
  c.forward_s = time_median_s(
                    [&]() {
                      torch::NoGradGuard no_grad;
                      for (std::int64_t k = 0; k < calls; ++k) loss_of(net, obs);
                    },
                    repeats) /
                static_cast<double>(calls * b);
  c.forward_backward_s = time_median_s(
                             [&]() {
                               for (std::int64_t k = 0; k < calls; ++k) {
                                 for (auto& p : net->parameters()) p.mutable_grad() = torch::Tensor();
                                 loss_of(net, obs).backward();
                               }
                             },
                             repeats) /
                         static_cast<double>(calls * b);
  return c;
}

// Seconds per sample of `concurrent` forward+backward passes at once on the OpenMP threads, as
// the agents run a minibatch's chunks (wall time / all samples).
template <class Net, class Obs, class LossOf>
double concurrent_forward_backward_s(Net& net, const Obs& obs, const LossOf& loss_of, std::int64_t batch, int repeats,
                                     int concurrent) {
  const std::int64_t calls = std::max<std::int64_t>(1, 8192 / batch);
  const auto params = net->parameters();
  return time_median_s(
             [&]() {
#pragma omp parallel for num_threads(concurrent) schedule(static, 1)
               for (int t = 0; t < concurrent; ++t)
                 for (std::int64_t k = 0; k < calls; ++k)
                   torch::autograd::grad({loss_of(net, obs)}, params, {}, false, false, true);
             },
             repeats) /
         static_cast<double>(calls * batch * concurrent);
}

// Seconds per sample of a network's fused training pass (models/kernels/attention_mlp_train.hpp):
// forward, then backward of the sum of the outputs, `concurrent` passes at once on the OpenMP
// threads, each over all the rows in an object of its own (the agents' concurrent chunks). `goal`:
// the observation's field between ego and the encoding (the LL's goal, the HL's previous action).
template <class Net>
double fused_train_s(const Net& net, const torch::Tensor& ego, const torch::Tensor& goal, const torch::Tensor& ado,
                     const torch::Tensor& ado_alive, const torch::Tensor& task, std::int64_t batch, int repeats,
                     int concurrent) {
  const std::int64_t calls = std::max<std::int64_t>(1, 8192 / batch);
  const models::kernels::AttentionMlpTrainNet view = net->train_net();
  std::vector<std::vector<torch::Tensor>> grads(static_cast<std::size_t>(concurrent));
  std::vector<models::kernels::AttentionMlpTrainGrads> grad_views;
  for (auto& g : grads) {
    for (const auto& p : net->parameters()) g.push_back(torch::empty_like(p));
    grad_views.push_back(net->train_grads(g));
  }
  const auto index = torch::arange(batch, torch::kInt64);
  models::kernels::TrainRows rows;
  rows.ego = ego.data_ptr<float>(), rows.goal = goal.data_ptr<float>(), rows.ado = ado.data_ptr<float>();
  rows.ado_alive = ado_alive.data_ptr<bool>(), rows.task = task.data_ptr<float>();
  rows.index = index.data_ptr<std::int64_t>();
  const auto width = static_cast<std::size_t>(batch * view.actor.back().out);
  std::vector<std::vector<float>> out(concurrent, std::vector<float>(width)),
      value(concurrent, std::vector<float>(static_cast<std::size_t>(batch)));
  const std::vector<float> ones(std::max(width, static_cast<std::size_t>(batch)), 1.0f);
  std::vector<models::kernels::AttentionMlpTrain> passes(static_cast<std::size_t>(concurrent));
  return time_median_s(
             [&]() {
#pragma omp parallel for num_threads(concurrent) schedule(static, 1)
               for (int t = 0; t < concurrent; ++t)
                 for (std::int64_t k = 0; k < calls; ++k) {
                   passes[t].forward(view, batch, rows, out[t].data(), value[t].data());
                   passes[t].backward(view, ones.data(), ones.data(), grad_views[t]);
                 }
             },
             repeats) /
         static_cast<double>(calls * batch * concurrent);
}

}  // namespace

SampleCost measure_ll_cost(const models::LlActorCriticConfig& cfg, std::int64_t batch, int repeats,
                           bool eigen_forward, int concurrent, double alive_share, bool fused_train) {
  auto gen = models::make_generator(1);
  const models::HlObs h = random_hl_obs(cfg.dims, batch, gen, alive_share);
  const models::LlObs obs{h.ego, h.prev_action, h.ado, h.ado_alive, h.task};
  models::LlActorCritic net(cfg);
  const auto loss_of = [](models::LlActorCritic& n, const models::LlObs& o) {
    const auto out = n(o);
    return out.mean.sum() + out.value.sum() + out.log_std.sum();
  };
  SampleCost c = measure_cost<models::LlActorCritic, models::LlObs>(net, obs, loss_of, batch, repeats);
  const std::int64_t calls = std::max<std::int64_t>(1, 8192 / batch);
  if (eigen_forward) {
    models::AttentionMlpForward fast;
    fast.set_weights(net->eigen_weights());
    auto mean = torch::empty({batch, cfg.action_dim}), value = torch::empty({batch});
    c.forward_s = time_median_s(
                      [&]() {
                        for (std::int64_t k = 0; k < calls; ++k)
                          fast.forward(batch, obs.ego.data_ptr<float>(), obs.goal.data_ptr<float>(),
                                       obs.ado.data_ptr<float>(), obs.ado_alive.data_ptr<bool>(),
                                       obs.task.data_ptr<float>(), mean.data_ptr<float>(), value.data_ptr<float>());
                      },
                      repeats) /
                  static_cast<double>(calls * batch);
  }
  if (fused_train)
    c.forward_backward_s =
        fused_train_s(net, obs.ego, obs.goal, obs.ado, obs.ado_alive, obs.task, batch, repeats, std::max(1, concurrent));
  else if (concurrent > 1)
    c.forward_backward_s = concurrent_forward_backward_s(net, obs, loss_of, batch, repeats, concurrent);
  return c;
}

SampleCost measure_hl_cost(const models::HlCriticConfig& cfg, std::int64_t batch, int repeats, int concurrent,
                           bool eigen_forward, double alive_share, bool fused_train) {
  auto gen = models::make_generator(1);
  const models::HlObs obs = random_hl_obs(cfg.dims, batch, gen, alive_share);
  models::HlCritic net(cfg);
  const auto loss_of = [](models::HlCritic& n, const models::HlObs& o) {
    const auto out = n(o);
    return out.log_probs.defined() ? out.log_probs.sum() : out.q.sum();
  };
  SampleCost c = measure_cost<models::HlCritic, models::HlObs>(net, obs, loss_of, batch, repeats);
  if (eigen_forward) {
    // As EsAgent::q_values runs it: the Eigen forward into the heads' output, q from it.
    const std::int64_t calls = std::max<std::int64_t>(1, 8192 / batch);
    models::AttentionMlpForward fast;
    fast.set_weights(net->eigen_weights());
    auto head = torch::empty({batch, net->head_width()});
    torch::NoGradGuard no_grad;
    c.forward_s = time_median_s(
                      [&]() {
                        for (std::int64_t k = 0; k < calls; ++k) {
                          fast.forward(batch, obs.ego.data_ptr<float>(), obs.prev_action.data_ptr<float>(),
                                       obs.ado.data_ptr<float>(), obs.ado_alive.data_ptr<bool>(),
                                       obs.task.data_ptr<float>(), head.data_ptr<float>(), nullptr);
                          net->from_head(head);
                        }
                      },
                      repeats) /
                  static_cast<double>(calls * batch);
  }
  if (fused_train)
    c.forward_backward_s = fused_train_s(net, obs.ego, obs.prev_action, obs.ado, obs.ado_alive, obs.task, batch,
                                         repeats, std::max(1, concurrent));
  else if (concurrent > 1)
    c.forward_backward_s = concurrent_forward_backward_s(net, obs, loss_of, batch, repeats, concurrent);
  return c;
}

double matmul_gflops(int repeats) {
  constexpr std::int64_t n = 1024;
  auto gen = models::make_generator(2);
  const auto a = torch::randn({n, n}, gen), b = torch::randn({n, n}, gen);
  torch::Tensor c = torch::empty({n, n});
  torch::NoGradGuard no_grad;
  const double s = time_median_s([&]() { torch::mm_out(c, a, b); }, repeats);
  return 2.0 * n * n * n / s * 1e-9;
}

double fixed_order_gemm_gflops(models::kernels::GemmIsa isa, int repeats) {
  constexpr std::int64_t m = 459, k = 101, n = 64, calls = 200;
  auto gen = models::make_generator(3);
  const auto a = torch::randn({m, k}, gen), b = torch::randn({k, n}, gen), bias = torch::randn({n}, gen);
  torch::Tensor c = torch::empty({m, n});
  models::kernels::GemmArgs g;
  g.m = m, g.n = n, g.k = k;
  g.a = a.data_ptr<float>(), g.a_row_stride = k;
  g.b = b.data_ptr<float>(), g.b_row_stride = n;
  g.bias = bias.data_ptr<float>();
  g.c = c.data_ptr<float>(), g.c_row_stride = n;
  const double s = time_median_s([&]() {
    for (int i = 0; i < calls; ++i) models::kernels::fixed_order_gemm(g, isa);
  }, repeats);
  return 2.0 * m * n * k * calls / s * 1e-9;
}

}  // namespace f16race::bench
