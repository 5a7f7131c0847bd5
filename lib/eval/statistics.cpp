#include "eval/statistics.hpp"

#include <algorithm>
#include <cmath>
#include <stdexcept>

#include "random/random_stream.hpp"

namespace f16race::eval {

double mean(const std::vector<double>& x) {
  if (x.empty()) return std::nan("");
  double s = 0.0;
  for (double v : x) s += v;
  return s / static_cast<double>(x.size());
}

double stddev(const std::vector<double>& x) {
  if (x.size() < 2) return 0.0;
  const double m = mean(x);
  double s = 0.0;
  for (double v : x) s += (v - m) * (v - m);
  return std::sqrt(s / static_cast<double>(x.size() - 1));
}

double iqm(std::vector<double> x) {
  if (x.empty()) return std::nan("");
  std::sort(x.begin(), x.end());
  const std::size_t cut = x.size() / 4;
  double s = 0.0;
  for (std::size_t k = cut; k < x.size() - cut; ++k) s += x[k];
  return s / static_cast<double>(x.size() - 2 * cut);
}

namespace {
// Linear-interpolation percentile (numpy's default) of sorted data, q in [0, 100].
double percentile(const std::vector<double>& sorted, double q) {
  const double pos = q / 100.0 * static_cast<double>(sorted.size() - 1);
  const std::size_t lo = static_cast<std::size_t>(std::floor(pos));
  const std::size_t hi = std::min(lo + 1, sorted.size() - 1);
  return sorted[lo] + (pos - static_cast<double>(lo)) * (sorted[hi] - sorted[lo]);
}
}  // namespace

Interval iqm_with_ci(const std::vector<std::vector<double>>& scores, int replicates, double alpha, std::uint64_t seed) {
  if (scores.empty() || scores[0].empty()) throw std::invalid_argument("iqm_with_ci: no scores");
  const std::size_t runs = scores.size(), tasks = scores[0].size();
  for (const auto& r : scores)
    if (r.size() != tasks) throw std::invalid_argument("iqm_with_ci: every run needs a score for every task");
  std::vector<double> all;
  for (const auto& r : scores) all.insert(all.end(), r.begin(), r.end());
  Interval out;
  out.point = iqm(all);
  RandomStream rng(seed, 0xB007);
  std::vector<double> reps, sample(runs * tasks);
  reps.reserve(static_cast<std::size_t>(replicates));
  for (int b = 0; b < replicates; ++b) {
    for (std::size_t t = 0; t < tasks; ++t)
      for (std::size_t r = 0; r < runs; ++r) sample[t * runs + r] = scores[static_cast<std::size_t>(rng.below(static_cast<int>(runs)))][t];
    reps.push_back(iqm(sample));
  }
  std::sort(reps.begin(), reps.end());
  out.lo = percentile(reps, 100.0 * alpha / 2.0);
  out.hi = percentile(reps, 100.0 * (1.0 - alpha / 2.0));
  return out;
}

Interval wilson_interval(double successes, double trials, double z) {
  if (!(trials > 0.0)) return Interval{std::nan(""), std::nan(""), std::nan("")};
  const double p = successes / trials, z2 = z * z;
  const double denom = 1.0 + z2 / trials;
  const double centre = (p + z2 / (2.0 * trials)) / denom;
  const double half = z * std::sqrt(p * (1.0 - p) / trials + z2 / (4.0 * trials * trials)) / denom;
  // At p = 0 (1) the lower (upper) bound is exactly 0 (1); rounding would leave ~1e-19.
  return Interval{p, p <= 0.0 ? 0.0 : std::max(0.0, centre - half), p >= 1.0 ? 1.0 : std::min(1.0, centre + half)};
}

}  // namespace f16race::eval
