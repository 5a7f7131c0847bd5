#include "agents/kernels/adam_kernel.hpp"

#include <cmath>

namespace f16race::agents::kernels {

double sum_of_squares(const float* g, std::int64_t n) {
  // Eight partial sums: the loop vectorises and the order is fixed by n alone.
  double acc[8] = {};
  std::int64_t i = 0;
  for (; i + 8 <= n; i += 8)
    for (int k = 0; k < 8; ++k) acc[k] += static_cast<double>(g[i + k]) * static_cast<double>(g[i + k]);
  for (; i < n; ++i) acc[0] += static_cast<double>(g[i]) * static_cast<double>(g[i]);
  return ((acc[0] + acc[1]) + (acc[2] + acc[3])) + ((acc[4] + acc[5]) + (acc[6] + acc[7]));
}

void adam_update(const AdamScalars& s, const float* __restrict g, float* __restrict m, float* __restrict v,
                 float* __restrict p, std::int64_t n) {
  for (std::int64_t i = 0; i < n; ++i) {
    const float gi = s.grad_scale * g[i];
    const float mi = s.beta1 * m[i] + s.one_minus_beta1 * gi;
    const float vi = s.beta2 * v[i] + s.one_minus_beta2 * (gi * gi);
    m[i] = mi;
    v[i] = vi;
    p[i] -= s.step_size * (mi / (std::sqrt(vi) * s.inv_sqrt_bias_correction2 + s.eps));
  }
}

}  // namespace f16race::agents::kernels
