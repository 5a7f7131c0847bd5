// The fused optimiser step (agents/optimizer_step.hpp) against LibTorch's clip_grad_norm_ +
// Adam, which stay the oracle: same parameters and moments to float rounding, over steps with
// and without clipping, a parameter without a gradient, and a state read back from a checkpoint.
#include <gtest/gtest.h>
#include <torch/torch.h>

#include <sstream>

#include "agents/checkpoint.hpp"
#include "agents/optimizer_step.hpp"

namespace f16race::agents {
namespace {

struct Net : torch::nn::Module {
  Net() {
    a = register_module("a", torch::nn::Linear(7, 13));
    b = register_module("b", torch::nn::Linear(13, 5));
    unused = register_parameter("unused", torch::randn({3}));
  }
  torch::Tensor forward(const torch::Tensor& x) { return b(torch::tanh(a(x))); }
  torch::nn::Linear a{nullptr}, b{nullptr};
  torch::Tensor unused;
};

// One gradient on `net` from a fixed batch, scaled so that clipping at 0.5 is active when
// `big` (the loss's gradient norm is ~1e2 then) and inactive otherwise.
void make_gradient(Net& net, int step, bool big) {
  torch::manual_seed(100 + step);
  const auto x = torch::randn({32, 7}), y = torch::randn({32, 5});
  auto loss = (net.forward(x) - y).pow(2).mean() * (big ? 1000.0 : 0.01);
  for (auto& p : net.parameters()) p.mutable_grad() = torch::Tensor();
  loss.backward();
}

double max_rel_diff(const torch::Tensor& x, const torch::Tensor& y) {
  return ((x - y).abs() / (y.abs() + 1e-6)).max().item<double>();
}

TEST(OptimizerStep, ClipAndAdamEqualLibTorchsOverManySteps) {
  torch::manual_seed(1);
  Net fused, oracle;
  torch::NoGradGuard no_grad_copy;
  for (std::size_t k = 0; k < fused.parameters().size(); ++k) oracle.parameters()[k].copy_(fused.parameters()[k]);
  torch::optim::Adam opt_fused(fused.parameters(), torch::optim::AdamOptions(3e-3).eps(1e-5));
  torch::optim::Adam opt_oracle(oracle.parameters(), torch::optim::AdamOptions(3e-3).eps(1e-5));
  int clipped = 0;
  for (int step = 0; step < 60; ++step) {
    const bool big = step % 3 == 0;
    {
      torch::AutoGradMode on(true);
      make_gradient(fused, step, big);
      make_gradient(oracle, step, big);
    }
    const double norm_oracle = torch::nn::utils::clip_grad_norm_(oracle.parameters(), 0.5);
    opt_oracle.step();
    const double norm_fused = clip_and_adam_step(opt_fused, 0.5);
    EXPECT_NEAR(norm_fused, norm_oracle, 1e-5 * norm_oracle) << "step " << step;
    clipped += norm_oracle > 0.5;
    if (step == 30) {  // the fused state through a checkpoint and back
      torch::serialize::OutputArchive out;
      write_adam(out, "adam", opt_fused);
      std::ostringstream bytes;
      out.save_to(bytes);
      torch::optim::Adam reread(fused.parameters(), torch::optim::AdamOptions(1.0));
      torch::serialize::InputArchive in;
      std::istringstream is(bytes.str());
      in.load_from(is);
      read_adam(in, "adam", reread);
      opt_fused.state().swap(reread.state());
    }
  }
  EXPECT_GE(clipped, 20);
  EXPECT_LE(clipped, 50);  // both regimes were exercised
  for (std::size_t k = 0; k < fused.parameters().size(); ++k)
    EXPECT_LT(max_rel_diff(fused.parameters()[k], oracle.parameters()[k]), 1e-4) << "parameter " << k;
  // The parameter that never had a gradient was never stepped, as LibTorch leaves it.
  EXPECT_TRUE(torch::equal(fused.unused, oracle.unused));
  EXPECT_EQ(opt_fused.state().count(c10::guts::to_string(fused.unused.unsafeGetTensorImpl())), 0u);
  const auto& sf = static_cast<torch::optim::AdamParamState&>(
      *opt_fused.state().at(c10::guts::to_string(fused.a->weight.unsafeGetTensorImpl())));
  const auto& so = static_cast<torch::optim::AdamParamState&>(
      *opt_oracle.state().at(c10::guts::to_string(oracle.a->weight.unsafeGetTensorImpl())));
  EXPECT_EQ(sf.step(), 60);
  EXPECT_EQ(sf.step(), so.step());
  EXPECT_LT(max_rel_diff(sf.exp_avg_sq(), so.exp_avg_sq()), 1e-3);
  EXPECT_LT((sf.exp_avg() - so.exp_avg()).abs().max().item<double>(), 1e-5 * so.exp_avg().abs().max().item<double>() + 1e-9);
}

TEST(OptimizerStep, ChunkGradientsSumInOrderIntoTheParametersOwnBuffer) {
  auto w = torch::zeros({4}, torch::requires_grad());
  auto u = torch::zeros({2}, torch::requires_grad());
  const std::vector<torch::Tensor> params{w, u};
  const std::vector<torch::Tensor> c0{torch::tensor({1.f, 2.f, 3.f, 4.f}), torch::Tensor()};
  const std::vector<torch::Tensor> c1{torch::tensor({0.5f, 0.5f, 0.5f, 0.5f}), torch::Tensor()};
  const std::vector<torch::Tensor> empty;
  sum_chunk_gradients(params, {&c0, &empty, &c1}, /*zero_unused=*/false);
  ASSERT_TRUE(w.grad().defined());
  EXPECT_TRUE(torch::equal(w.grad(), torch::tensor({1.5f, 2.5f, 3.5f, 4.5f})));
  EXPECT_FALSE(u.grad().defined());
  const float* buffer = w.grad().data_ptr<float>();
  sum_chunk_gradients(params, {&c1}, /*zero_unused=*/true);
  EXPECT_EQ(w.grad().data_ptr<float>(), buffer);  // reused, not reallocated
  EXPECT_TRUE(torch::equal(w.grad(), c1[0]));
  ASSERT_TRUE(u.grad().defined());
  EXPECT_TRUE(torch::equal(u.grad(), torch::zeros({2})));
  // A chunk's gradient is never aliased: changing it later leaves the sum alone.
  c1[0].add_(1.0f);
  EXPECT_FLOAT_EQ(w.grad()[0].item<float>(), 0.5f);
}

}  // namespace
}  // namespace f16race::agents
