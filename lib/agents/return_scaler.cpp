#include "agents/return_scaler.hpp"

#include <cmath>

namespace f16race::agents {

ReturnScaler::ReturnScaler(std::int64_t columns, double gamma) : gamma_(gamma) {
  s_.g.assign(static_cast<std::size_t>(columns), 0.0);
}

void ReturnScaler::observe(std::int64_t k, double reward, bool valid, bool ended) {
  double& g = s_.g[static_cast<std::size_t>(k)];
  if (!valid) {
    g = 0.0;
    return;
  }
  g = gamma_ * g + reward;
  s_.batch_count += 1.0;
  const double d = g - s_.batch_mean;
  s_.batch_mean += d / s_.batch_count;
  s_.batch_m2 += d * (g - s_.batch_mean);
  if (ended) g = 0.0;
}

double ReturnScaler::end_rollout() {
  if (s_.batch_count > 0.0) {
    // Chan et al.'s merge of two (count, mean, M2) summaries.
    const double n = s_.count + s_.batch_count;
    const double d = s_.batch_mean - s_.mean;
    s_.m2 += s_.batch_m2 + d * d * s_.count * s_.batch_count / n;
    s_.mean += d * s_.batch_count / n;
    s_.count = n;
    s_.batch_count = s_.batch_mean = s_.batch_m2 = 0.0;
  }
  if (s_.count == 0.0) return 1.0;
  return 1.0 / std::sqrt(s_.m2 / s_.count + 1e-8);
}

}  // namespace f16race::agents
