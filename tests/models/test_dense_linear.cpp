// dense_linear (the fixed-order kernels as an autograd node) against LibTorch's own linear, the
// oracle: values and every gradient to float rounding, for 2-D and 3-D inputs, inputs that need
// no gradient, and an MLP through forward_mlp.
#include <gtest/gtest.h>
#include <torch/torch.h>

#include "models/dense_linear.hpp"
#include "models/obs.hpp"

namespace f16race::models {
namespace {

void expect_close(const torch::Tensor& got, const torch::Tensor& want, const char* what) {
  ASSERT_EQ(got.sizes(), want.sizes()) << what;
  const double scale = want.abs().max().item<double>() + 1e-6;
  EXPECT_LT((got - want).abs().max().item<double>() / scale, 2e-6) << what;
}

TEST(DenseLinear, ValuesAndGradientsEqualLibTorchsLinear) {
  at::Generator g = make_generator(3);
  for (const auto& shape : {std::vector<int64_t>{459, 101}, std::vector<int64_t>{37, 7, 12}, std::vector<int64_t>{1, 5}}) {
    for (int64_t out : {1, 3, 64, 65}) {
      const int64_t in = shape.back();
      auto x = torch::randn(shape, g).requires_grad_(true);
      auto w = torch::randn({out, in}, g).requires_grad_(true);
      auto b = torch::randn({out}, g).requires_grad_(true);
      auto x2 = x.detach().clone().requires_grad_(true), w2 = w.detach().clone().requires_grad_(true),
           b2 = b.detach().clone().requires_grad_(true);
      const auto y = dense_linear(x, w, b);
      const auto y2 = torch::nn::functional::linear(x2, w2, b2);
      expect_close(y, y2, "y");
      const auto dy = torch::randn(y.sizes(), g);
      (y * dy).sum().backward();
      (y2 * dy).sum().backward();
      expect_close(x.grad(), x2.grad(), "dx");
      expect_close(w.grad(), w2.grad(), "dW");
      expect_close(b.grad(), b2.grad(), "db");
    }
  }
}

TEST(DenseLinear, AnInputWithoutGradientGetsNone) {
  at::Generator g = make_generator(4);
  const auto x = torch::randn({20, 9}, g);
  auto w = torch::randn({6, 9}, g).requires_grad_(true);
  const auto b = torch::randn({6}, g);
  dense_linear(x, w, b).pow(2).sum().backward();
  EXPECT_TRUE(w.grad().defined());
  EXPECT_FALSE(x.grad().defined());
  torch::NoGradGuard no_grad;
  expect_close(dense_linear(x, w, b), torch::nn::functional::linear(x, w, b), "no-grad forward");
}

TEST(DenseLinear, ForwardMlpEqualsTheSequentialsOwnForward) {
  torch::manual_seed(5);
  torch::nn::Sequential mlp(torch::nn::Linear(10, 64), torch::nn::Tanh(), torch::nn::Linear(64, 64), torch::nn::ReLU(),
                            torch::nn::Linear(64, 3));
  at::Generator g = make_generator(5);
  const auto x = torch::randn({300, 10}, g);
  expect_close(forward_mlp(mlp, x), mlp->forward(x), "mlp");
  torch::nn::Sequential odd(torch::nn::Linear(10, 4), torch::nn::Sigmoid());
  EXPECT_THROW(forward_mlp(odd, x), c10::Error);
}

TEST(DenseLinear, RefusesMismatchedShapes) {
  EXPECT_THROW(dense_linear(torch::zeros({4, 5}), torch::zeros({3, 6}), torch::zeros({3})), c10::Error);
  EXPECT_THROW(dense_linear(torch::zeros({4, 5}), torch::zeros({3, 5}), torch::zeros({4})), c10::Error);
}

}  // namespace
}  // namespace f16race::models
