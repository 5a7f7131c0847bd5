// The vectorisable math kernels against glibc over the ranges the model uses.
#include <gtest/gtest.h>

#include <cmath>

#include "dynamics/engine.hpp"
#include "dynamics/vector_math.hpp"

namespace f16race::dynamics {
namespace {

TEST(VectorMath, SinCosWithinTwoUlpOfLibmOverManyTurns) {
  double worst = 0.0;
  for (int k = -200000; k <= 200000; ++k) {
    const double x = k * 1e-3 + 1e-7 * (k % 13);  // -200..200 rad, off-grid
    double s, c;
    vmath::sincos(x, &s, &c);
    worst = std::fmax(worst, std::fabs(s - std::sin(x)));
    worst = std::fmax(worst, std::fabs(c - std::cos(x)));
  }
  EXPECT_LT(worst, 4.5e-16);
  double s, c;
  vmath::sincos(std::nan(""), &s, &c);
  EXPECT_TRUE(std::isnan(s) && std::isnan(c));
}

TEST(VectorMath, FloatSinCosWithin2e7OfLibmInEveryQuadrant) {
  double worst = 0.0;
  for (int k = -200000; k <= 200000; ++k) {
    const float x = static_cast<float>(k * 5e-4 + 1e-7 * (k % 13));  // -100..100 rad
    float s, c;
    vmath::sincosf(x, &s, &c);
    worst = std::fmax(worst, std::fabs(s - std::sin(static_cast<double>(x))));
    worst = std::fmax(worst, std::fabs(c - std::cos(static_cast<double>(x))));
  }
  EXPECT_LT(worst, 2e-7);
  float s, c;
  vmath::sincosf(-3.0f * static_cast<float>(M_PI) / 4.0f, &s, &c);  // third quadrant: both negative
  EXPECT_NEAR(s, -std::sqrt(0.5), 1e-7);
  EXPECT_NEAR(c, -std::sqrt(0.5), 1e-7);
}

TEST(VectorMath, DensityPowerMatchesStdPow) {
  double worst = 0.0;
  for (int k = 0; k <= 12000; ++k) {
    const double x = 0.3 + k * 1e-4;  // temperature ratio from ~100,000 ft below sea level up
    worst = std::fmax(worst, std::fabs(vmath::pow_4_14(x) / std::pow(x, 4.14) - 1.0));
  }
  EXPECT_LT(worst, 2e-15);
}

TEST(VectorMath, AtmosphereMatchesClosedForm) {
  // Sea level: rho = 2.377e-3, a = sqrt(1.4 * 1716.3 * 519) ft/s.
  const AirData sl = air_data(500.0, 0.0);
  EXPECT_NEAR(sl.qbar_psf, 0.5 * 2.377e-3 * 500.0 * 500.0, 1e-12);
  EXPECT_NEAR(sl.mach, 500.0 / std::sqrt(1.4 * 1716.3 * 519.0), 1e-15);
  // Stratosphere: temperature fixed at 390 R above 35,000 ft.
  EXPECT_NEAR(air_data(600.0, 40000.0).mach, 600.0 / std::sqrt(1.4 * 1716.3 * 390.0), 1e-15);
}

}  // namespace
}  // namespace f16race::dynamics
