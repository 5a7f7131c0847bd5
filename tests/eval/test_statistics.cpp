// Tournament statistics against hand-computed values and scipy/rliable conventions.
#include <gtest/gtest.h>

#include <cmath>

#include "eval/statistics.hpp"

namespace f16race::eval {
namespace {

TEST(Statistics, MeanAndSampleStd) {
  EXPECT_DOUBLE_EQ(mean({1, 2, 3, 4}), 2.5);
  EXPECT_NEAR(stddev({1, 2, 3, 4}), std::sqrt(5.0 / 3.0), 1e-15);
  EXPECT_EQ(stddev({7}), 0.0);
}

TEST(Statistics, IqmIsScipyTrimMeanWithAQuarterCut) {
  // scipy.stats.trim_mean([1..8], 0.25) cuts 2 from each end: mean(3, 4, 5, 6) = 4.5.
  EXPECT_DOUBLE_EQ(iqm({8, 1, 7, 2, 6, 3, 5, 4}), 4.5);
  // n = 10: floor(2.5) = 2 cut from each end; an outlier does not move it.
  EXPECT_DOUBLE_EQ(iqm({0, 1, 2, 3, 4, 5, 6, 7, 8, 1000}), 4.5);
  EXPECT_DOUBLE_EQ(iqm({2, 2, 2}), 2.0);  // n < 4: nothing is cut
}

TEST(Statistics, BootstrapIntervalBracketsThePointAndShrinksWithData) {
  std::vector<std::vector<double>> few, many;
  for (int r = 0; r < 5; ++r) few.push_back({0.5 + 0.05 * r, 0.6 - 0.03 * r});
  for (int r = 0; r < 50; ++r) many.push_back({0.5 + 0.05 * (r % 5), 0.6 - 0.03 * (r % 5)});
  const Interval a = iqm_with_ci(few, 2000, 0.05, 1), b = iqm_with_ci(many, 2000, 0.05, 1);
  EXPECT_LE(a.lo, a.point);
  EXPECT_GE(a.hi, a.point);
  EXPECT_LT(b.hi - b.lo, 0.6 * (a.hi - a.lo));  // ~1/sqrt(10) narrower with 10x the runs
  EXPECT_EQ(iqm_with_ci(few, 500, 0.05, 7).lo, iqm_with_ci(few, 500, 0.05, 7).lo);  // deterministic
  // Identical runs: no spread at all.
  const Interval c = iqm_with_ci({{0.7, 0.7}, {0.7, 0.7}, {0.7, 0.7}});
  EXPECT_DOUBLE_EQ(c.lo, 0.7);
  EXPECT_DOUBLE_EQ(c.hi, 0.7);
}

TEST(Statistics, WilsonIntervalMatchesHandValues) {
  // 8 of 10, z = 1.96: centre (0.8 + 0.19208) / 1.38416 = 0.716738, half width
  // 1.96 sqrt(0.016 + 0.009604) / 1.38416 = 0.226581: [0.490157, 0.943319].
  const Interval a = wilson_interval(8, 10, 1.96);
  EXPECT_DOUBLE_EQ(a.point, 0.8);
  EXPECT_NEAR(a.lo, 0.490157, 1e-6);
  EXPECT_NEAR(a.hi, 0.943319, 1e-6);
  // 0 of n: [0, z^2 / (n + z^2)]; 768 races (the README's untrained entry): [0, 0.004977].
  const Interval b = wilson_interval(0, 768);
  EXPECT_EQ(b.lo, 0.0);
  EXPECT_NEAR(b.hi, 3.841459 / (768 + 3.841459), 1e-6);
  // n of n mirrors it; draws counted half keep it symmetric around 0.5.
  const Interval c = wilson_interval(768, 768);
  EXPECT_EQ(c.hi, 1.0);
  EXPECT_NEAR(c.lo, 1.0 - b.hi, 1e-12);
  const Interval d = wilson_interval(2.5, 5);
  EXPECT_NEAR(d.lo + d.hi, 1.0, 1e-12);
  EXPECT_TRUE(std::isnan(wilson_interval(0, 0).point));
}

}  // namespace
}  // namespace f16race::eval
