#pragma once
// Branch-free sin/cos, log and power that GCC can vectorise inside `#pragma omp simd` loops.
// glibc's scalar sin/cos/pow are opaque calls that stop the vectoriser; these inline versions
// are accurate to a few ulp over the ranges the F-16 model needs, which is far below the 1e-9
// relative tolerance we hold against AeroBench, and they give the same bits on every machine.
#include <cmath>

#if defined(__GNUC__)
#define F16_INLINE inline __attribute__((always_inline))
#else
#define F16_INLINE inline
#endif

namespace f16race::dynamics::vmath {

// pi/2 split in three parts (Cody-Waite) so that x - k*pi/2 stays exact for |k| < 2^20;
// constants from fdlibm's e_rem_pio2.c (Sun Microsystems, public).
inline constexpr double kTwoOverPi = 6.36619772367581382433e-01;
inline constexpr double kPio2Hi = 1.57079632673412561417e+00;
inline constexpr double kPio2Mid = 6.07710050630396597660e-11;
inline constexpr double kPio2Lo = 2.02226624879595063154e-21;

// Minimax coefficients of sin and cos on [-pi/4, pi/4]; fdlibm k_sin.c / k_cos.c.
inline constexpr double kS1 = -1.66666666666666324348e-01;
inline constexpr double kS2 = 8.33333333332248946124e-03;
inline constexpr double kS3 = -1.98412698298579493134e-04;
inline constexpr double kS4 = 2.75573137070700676789e-06;
inline constexpr double kS5 = -2.50507602534068634195e-08;
inline constexpr double kS6 = 1.58969099521155010221e-10;
inline constexpr double kC1 = 4.16666666666666019037e-02;
inline constexpr double kC2 = -1.38888888888741095749e-03;
inline constexpr double kC3 = 2.48015872894767294178e-05;
inline constexpr double kC4 = -2.75573143513906633035e-07;
inline constexpr double kC5 = 2.08757232129817482790e-09;
inline constexpr double kC6 = -1.13596475577881948265e-11;

// sin and cos of x together. Accurate for |x| < 1e6 rad; a NaN input gives NaN outputs.
F16_INLINE void sincos(double x, double* s_out, double* c_out) {
  const double k = std::floor(x * kTwoOverPi + 0.5);
  double r = x - k * kPio2Hi;
  r -= k * kPio2Mid;
  r -= k * kPio2Lo;
  const double quadrant = k - 4.0 * std::floor(k * 0.25);  // k mod 4, in {0, 1, 2, 3}
  const double r2 = r * r;
  const double sin_r = r + r * r2 * (kS1 + r2 * (kS2 + r2 * (kS3 + r2 * (kS4 + r2 * (kS5 + r2 * kS6)))));
  const double cos_r =
      1.0 - 0.5 * r2 + r2 * r2 * (kC1 + r2 * (kC2 + r2 * (kC3 + r2 * (kC4 + r2 * (kC5 + r2 * kC6)))));
  const double s = (quadrant == 0.0) ? sin_r : (quadrant == 1.0) ? cos_r : (quadrant == 2.0) ? -sin_r : -cos_r;
  const double c = (quadrant == 0.0) ? cos_r : (quadrant == 1.0) ? -sin_r : (quadrant == 2.0) ? -cos_r : sin_r;
  *s_out = s;
  *c_out = c;
}

// Single-precision sin and cos together, for observations (float buffers): 16 lanes per
// AVX-512 vector instead of 8. Absolute error < 2e-7 for |x| < 1e4 rad. pi/2 split and the
// minimax coefficients on [-pi/4, pi/4] are Cephes sinf.c / cosf.c (S. L. Moshier, public).
F16_INLINE void sincosf(float x, float* s_out, float* c_out) {
  const float k = std::floor(x * 0.636619772f + 0.5f);
  float r = x - k * 1.5703125f;
  r -= k * 4.837512969970703125e-4f;
  r -= k * 7.54978995489188216e-8f;
  // Quadrant as an integer: GCC vectorises these selects, not the float-compare chain.
  const int q = static_cast<int>(k) & 3;
  const float r2 = r * r;
  const float sin_r = r + r * r2 * (-1.6666654611e-1f + r2 * (8.3321608736e-3f + r2 * -1.9515295891e-4f));
  const float cos_r =
      1.0f - 0.5f * r2 + r2 * r2 * (4.166664568298827e-2f + r2 * (-1.388731625493765e-3f + r2 * 2.443315711809948e-5f));
  const float s = (q & 1) ? cos_r : sin_r;
  const float c = (q & 1) ? sin_r : cos_r;
  *s_out = (q & 2) ? -s : s;
  *c_out = ((q + 1) & 2) ? -c : c;
}

// Natural log for x in about [0.05, 20]: two square roots (exactly rounded in hardware) bring
// y = x^(1/4) near 1, then log(x) = 8 atanh((y - 1) / (y + 1)) by its odd series.
F16_INLINE double log_near_one(double x) {
  const double y = std::sqrt(std::sqrt(x));
  const double s = (y - 1.0) / (y + 1.0);
  const double s2 = s * s;
  double p = 1.0 / 25.0;
  p = p * s2 + 1.0 / 23.0;
  p = p * s2 + 1.0 / 21.0;
  p = p * s2 + 1.0 / 19.0;
  p = p * s2 + 1.0 / 17.0;
  p = p * s2 + 1.0 / 15.0;
  p = p * s2 + 1.0 / 13.0;
  p = p * s2 + 1.0 / 11.0;
  p = p * s2 + 1.0 / 9.0;
  p = p * s2 + 1.0 / 7.0;
  p = p * s2 + 1.0 / 5.0;
  p = p * s2 + 1.0 / 3.0;
  p = p * s2 + 1.0;
  return 8.0 * s * p;
}

// exp(y) for |y| < 0.5 by its Taylor series (Horner), error below one ulp there.
F16_INLINE double exp_small(double y) {
  double p = 1.0 / 6227020800.0;  // 1/13!
  p = p * y + 1.0 / 479001600.0;
  p = p * y + 1.0 / 39916800.0;
  p = p * y + 1.0 / 3628800.0;
  p = p * y + 1.0 / 362880.0;
  p = p * y + 1.0 / 40320.0;
  p = p * y + 1.0 / 5040.0;
  p = p * y + 1.0 / 720.0;
  p = p * y + 1.0 / 120.0;
  p = p * y + 1.0 / 24.0;
  p = p * y + 1.0 / 6.0;
  p = p * y + 0.5;
  p = p * y + 1.0;
  return p * y + 1.0;
}

// x^4.14 for x in about [0.3, 1.5] (the atmosphere's temperature ratio up to ~100,000 ft):
// x^4 by products and x^0.14 = exp(0.14 log x) with a small exponent, so both series converge.
F16_INLINE double pow_4_14(double x) {
  const double x2 = x * x;
  return (x2 * x2) * exp_small(0.14 * log_near_one(x));
}

}  // namespace f16race::dynamics::vmath
