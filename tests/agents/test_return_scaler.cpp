// The return scaler: per-column discounted returns restarted at episode ends and at invalid
// samples, their population variance over every rollout so far, and the factor 1/sqrt(var+1e-8).
#include <gtest/gtest.h>

#include <cmath>
#include <random>
#include <vector>

#include "agents/return_scaler.hpp"

namespace f16race::agents {
namespace {

double factor_of(const std::vector<double>& returns) {
  double mean = 0.0, var = 0.0;
  for (double g : returns) mean += g / static_cast<double>(returns.size());
  for (double g : returns) var += (g - mean) * (g - mean) / static_cast<double>(returns.size());
  return 1.0 / std::sqrt(var + 1e-8);
}

// Worked by hand with gamma 0.5: the returns seen are 1, 2, 1.5 (column 0's episode ends after
// its second step), then 2 (column 0 restarted) and 4 (column 1 restarted by an invalid sample).
TEST(ReturnScaler, HandWorkedReturns) {
  ReturnScaler s(2, 0.5);
  EXPECT_EQ(s.end_rollout(), 1.0) << "nothing seen: rewards unchanged";
  s.observe(0, 1.0, true, false);
  s.observe(1, 2.0, true, false);
  s.observe(0, 1.0, true, true);  // G = 0.5 * 1 + 1 = 1.5, then restarted
  EXPECT_DOUBLE_EQ(s.end_rollout(), 1.0 / std::sqrt(0.5 / 3.0 + 1e-8));
  s.observe(0, 2.0, true, false);   // G = 2
  s.observe(1, 9.0, false, false);  // not counted; restarts column 1
  s.observe(1, 4.0, true, false);   // G = 4
  EXPECT_NEAR(s.end_rollout(), 1.0 / std::sqrt(1.04 + 1e-8), 1e-12);
  EXPECT_EQ(s.stats().count, 5.0);
  EXPECT_DOUBLE_EQ(s.stats().mean, 2.1);
}

// Many rollouts of random rewards and ends: the merged statistics give the factor of the
// population variance of every return seen, computed in one pass at the end.
TEST(ReturnScaler, MergedRolloutsEqualOnePassOverEveryReturn) {
  std::mt19937 rng(5);
  std::normal_distribution<double> reward(0.3, 2.0);
  std::bernoulli_distribution ends(0.05), invalid(0.02);
  const int columns = 7;
  const double gamma = 0.99;
  ReturnScaler s(columns, gamma);
  std::vector<double> g(columns, 0.0), seen;
  for (int rollout = 0; rollout < 20; ++rollout) {
    for (int step = 0; step < 32; ++step)
      for (int k = 0; k < columns; ++k) {
        const double r = reward(rng);
        const bool valid = !invalid(rng), ended = ends(rng);
        s.observe(k, r, valid, ended);
        if (!valid) {
          g[k] = 0.0;
          continue;
        }
        g[k] = gamma * g[k] + r;
        seen.push_back(g[k]);
        if (ended) g[k] = 0.0;
      }
    const double f = s.end_rollout();
    EXPECT_NEAR(f, factor_of(seen), 1e-12 * factor_of(seen)) << "rollout " << rollout;
  }
  EXPECT_EQ(s.stats().g, g);
}

}  // namespace
}  // namespace f16race::agents
