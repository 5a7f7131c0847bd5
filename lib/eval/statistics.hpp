#pragma once
// Honest aggregate statistics for tournaments, following rliable (Agarwal et al., "Deep RL at the
// Edge of the Statistical Precipice", NeurIPS 2021): the interquartile mean with a stratified
// percentile-bootstrap confidence interval, besides the plain mean and standard deviation.
#include <cstdint>
#include <vector>

namespace f16race::eval {

double mean(const std::vector<double>& x);
// Sample standard deviation (n - 1 in the denominator); 0 for fewer than two values.
double stddev(const std::vector<double>& x);
// 25 % trimmed mean, as scipy.stats.trim_mean(x, 0.25) that rliable uses: floor(n / 4) values are
// cut from each end of the sorted data and the rest averaged.
double iqm(std::vector<double> x);

struct Interval {
  double point = 0.0;  // the statistic on the data
  double lo = 0.0;     // percentile bounds of the bootstrap distribution
  double hi = 0.0;
};

// IQM of scores[run][task] over all runs and tasks, with a stratified bootstrap CI: each
// replicate resamples runs with replacement independently within every task (rliable's
// StratifiedBootstrap), recomputes the IQM, and the CI is the (alpha/2, 1 - alpha/2) percentile
// range of the replicates. Deterministic for a given seed.
Interval iqm_with_ci(const std::vector<std::vector<double>>& scores, int replicates = 2000, double alpha = 0.05,
                     std::uint64_t seed = 0);

// Wilson score interval of a binomial proportion: `successes` of `trials` (successes may be
// fractional, e.g. draws counted half), z = 1.96 for 95 %. point = successes / trials; lo and
// hi are clamped to [0, 1] (exactly 0 / 1 at p = 0 / 1). NaN everywhere when trials is 0.
Interval wilson_interval(double successes, double trials, double z = 1.959963984540054);

}  // namespace f16race::eval
