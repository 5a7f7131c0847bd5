// Properties of the table look-ups and the engine that the reference points do not pin down:
// exact values at breakpoints, linear extrapolation past the ends, symmetry, branch edges.
#include <gtest/gtest.h>

#include <cmath>

#include "dynamics/engine.hpp"
#include "dynamics/stevens_aero.hpp"

namespace f16race::dynamics {
namespace {

TEST(StevensTables, BreakpointsReturnTableEntries) {
  // C_X at alpha = 20 deg (column 6), elevator 0 (row 2) is 0.128 in Stevens & Lewis.
  EXPECT_DOUBLE_EQ(stevens_cx(20.0, 0.0), 0.128);
  EXPECT_DOUBLE_EQ(stevens_cm(-10.0, -24.0), 0.205);
  EXPECT_DOUBLE_EQ(stevens_cz(45.0, 0.0, 0.0), -2.229);
  EXPECT_DOUBLE_EQ(stevens_damping(0.0).d[6], -5.23);  // Cmq at alpha 0
}

TEST(StevensTables, ExtrapolatesLinearlyBeyondTheEnds) {
  // Past 45 deg the last two alpha columns are extended: cz(50) = 2*cz(45) - cz(40).
  EXPECT_NEAR(stevens_cz(50.0, 0.0, 0.0), 2 * -2.229 - -2.248, 1e-15);
  EXPECT_NEAR(stevens_cz(-15.0, 0.0, 0.0), 2 * 0.770 - 0.241, 1e-15);
}

TEST(StevensTables, RollAndYawMomentsAreOddInSideslip) {
  for (double a : {-7.0, 3.0, 12.5, 33.0})
    for (double b : {2.0, 7.5, 18.0}) {
      EXPECT_DOUBLE_EQ(stevens_cl(a, -b), -stevens_cl(a, b));
      EXPECT_DOUBLE_EQ(stevens_cn(a, -b), -stevens_cn(a, b));
    }
  EXPECT_EQ(stevens_cl(10.0, 0.0), 0.0);
}

TEST(StevensTables, NanInputNeverReadsOutsideTheTables) {
  const double nan = std::nan("");
  EXPECT_TRUE(std::isnan(stevens_cx(nan, 0.0)));
  EXPECT_TRUE(std::isnan(stevens_dnda(10.0, nan)));
  EXPECT_TRUE(std::isnan(engine_thrust(50.0, nan, 0.5)));
}

TEST(Engine, PowerLagBranches) {
  EXPECT_DOUBLE_EQ(throttle_gearing(0.77), 64.94 * 0.77);
  EXPECT_DOUBLE_EQ(throttle_gearing(1.0), 100.0);
  EXPECT_DOUBLE_EQ(power_derivative(30.0, 40.0), 10.0);          // small step: rate 1/s
  EXPECT_DOUBLE_EQ(power_derivative(10.0, 80.0), 0.1 * 50.0);    // light-up aims at 60 %
  EXPECT_DOUBLE_EQ(power_derivative(70.0, 20.0), 5.0 * -30.0);   // from afterburner aims at 40 %
  EXPECT_DOUBLE_EQ(power_derivative(60.0, 90.0), 5.0 * 30.0);
}

TEST(Engine, ThrustAtBreakpointsAndMilitaryBlend) {
  // Sea level, Mach 0: idle 1060, military 12680, maximum 20000 lbf.
  EXPECT_DOUBLE_EQ(engine_thrust(0.0, 0.0, 0.0), 1060.0 + (12680.0 - 1060.0) * 0.0);
  EXPECT_NEAR(engine_thrust(50.0, 0.0, 0.0), 12680.0, 1e-6);
  EXPECT_NEAR(engine_thrust(100.0, 0.0, 0.0), 20000.0, 1e-6);
  EXPECT_NEAR(engine_thrust(25.0, 0.0, 0.0), 0.5 * (1060.0 + 12680.0), 1e-6);
}

}  // namespace
}  // namespace f16race::dynamics
