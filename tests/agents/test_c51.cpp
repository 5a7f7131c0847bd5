// C51 projection against hand-computed cases.
#include <gtest/gtest.h>
#include <torch/torch.h>

#include "agents/c51.hpp"
#include "models/obs.hpp"

namespace f16race::agents {
namespace {

// Support {-1, -0.5, 0, 0.5, 1}: dz = 0.5.
const C51Support kSupport{-1.0, 1.0, 5};

torch::Tensor project1(std::vector<float> p, float r, float discount) {
  return c51_project(torch::tensor(p).view({1, 5}), torch::tensor({r}), torch::tensor({discount}), kSupport)[0];
}

void expect_probs(const torch::Tensor& got, std::vector<float> want, double tol = 1e-6) {
  ASSERT_EQ(got.numel(), static_cast<int64_t>(want.size()));
  for (size_t k = 0; k < want.size(); ++k) EXPECT_NEAR(got[k].item<float>(), want[k], tol) << "atom " << k;
}

TEST(C51Projection, SplitsMassBetweenNeighbours) {
  // Atoms 2 (z=0) and 4 (z=1) with 0.5 each, r = 0.1, discount 0.5: Tz = 0.1 and 0.6, i.e.
  // b = 2.2 (0.8 to atom 2, 0.2 to atom 3) and b = 3.2 (0.8 to atom 3, 0.2 to atom 4).
  expect_probs(project1({0, 0, 0.5, 0, 0.5}, 0.1f, 0.5f), {0, 0, 0.4f, 0.1f + 0.4f, 0.1f});
}

TEST(C51Projection, TargetExactlyOnAnAtomKeepsAllMass) {
  // Terminal (discount 0), r = 0.5: everything on atom 3, nothing leaks to atom 2 or 4.
  expect_probs(project1({0.2f, 0.2f, 0.2f, 0.2f, 0.2f}, 0.5f, 0.0f), {0, 0, 0, 1, 0}, 0.0);
  // Shift by one atom: r = 0.5, discount 1 moves every atom one to the right, the top one clips.
  expect_probs(project1({0.1f, 0.2f, 0.3f, 0.15f, 0.25f}, 0.5f, 1.0f), {0, 0.1f, 0.2f, 0.3f, 0.4f});
}

TEST(C51Projection, ClipsAtTheEnds) {
  expect_probs(project1({0.3f, 0.1f, 0.2f, 0.2f, 0.2f}, 100.0f, 0.99f), {0, 0, 0, 0, 1});
  expect_probs(project1({0.3f, 0.1f, 0.2f, 0.2f, 0.2f}, -100.0f, 0.99f), {1, 0, 0, 0, 0});
  // r = -0.9, discount 0.5: Tz = -1.4 (clip to -1), -1.15 (clip), -0.9, -0.65, -0.4.
  // b = 0, 0, 0.2, 0.7, 1.2: atom 0 gets 0.2 + 0.2 + 0.8*0.2 + 0.3*0.2 = 0.62,
  // atom 1 gets 0.2*0.2 + 0.7*0.2 + 0.8*0.2 = 0.34, atom 2 gets 0.2*0.2 = 0.04.
  expect_probs(project1({0.2f, 0.2f, 0.2f, 0.2f, 0.2f}, -0.9f, 0.5f), {0.62f, 0.34f, 0.04f, 0, 0});
}

TEST(C51Projection, ConservesMassOnRandomInputs) {
  auto gen = models::make_generator(3);
  const C51Support support{-10.0, 10.0, 51};
  const int64_t n = 1000;
  const auto probs = torch::softmax(3.0 * torch::randn({n, 51}, gen, torch::kFloat32), 1);
  const auto reward = 4.0 * torch::randn({n}, gen, torch::kFloat32);
  const auto discount = 0.5 * (torch::rand({n}, gen) < 0.8).to(torch::kFloat32);
  const auto m = c51_project(probs, reward, discount, support);
  EXPECT_LT((m.sum(1) - 1.0).abs().max().item<double>(), 1e-5);
  EXPECT_GE(m.min().item<float>(), 0.0f);
  // The mean is preserved when no mass is clipped (|r| + 0.5 * 10 <= 10): E[m] = r + discount E[p].
  const auto z = support.atoms();
  const auto expected = reward + discount * (probs * z).sum(1);
  const auto inside = reward.abs() < 5.0;
  const auto got = (m * z).sum(1);
  ASSERT_GT(inside.sum().item<int64_t>(), 10);
  EXPECT_LT((got - expected).index({inside}).abs().max().item<double>(), 1e-4);
}

}  // namespace
}  // namespace f16race::agents
