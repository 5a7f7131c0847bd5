#pragma once
// The arithmetic of one Adam step and of a gradient norm, on raw float arrays, without LibTorch:
// compiled with the simulator's arch flags and -fno-math-errno so that sqrt and the division
// vectorise (agents/optimizer_step.hpp drives them over a network's parameters).
#include <cstdint>

namespace f16race::agents::kernels {

// Sum of squares of g[0..n), accumulated in double.
double sum_of_squares(const float* g, std::int64_t n);

// Per-step constants of an Adam update (torch.optim.Adam without weight decay or AMSGrad).
struct AdamScalars {
  float grad_scale = 1.0f;    // the clip factor applied to every gradient element
  float beta1 = 0.9f, beta2 = 0.999f;
  float one_minus_beta1 = 0.1f, one_minus_beta2 = 0.001f;
  float inv_sqrt_bias_correction2 = 1.0f;  // 1 / sqrt(1 - beta2^t)
  float eps = 1e-8f;
  float step_size = 1e-3f;    // lr / (1 - beta1^t)
};

// For each i: g' = grad_scale * g[i]; m = beta1 m + (1 - beta1) g'; v = beta2 v + (1 - beta2) g'^2;
// p -= step_size * m / (sqrt(v) / sqrt(1 - beta2^t) + eps). m, v and p in place.
void adam_update(const AdamScalars& s, const float* g, float* m, float* v, float* p, std::int64_t n);

}  // namespace f16race::agents::kernels
