#pragma once
// Air data and engine of the AeroBench F-16 (lowlevel/adc.py, tgear.py, rtau.py, pdot.py,
// thrust.py). Written branch-free (selects instead of ifs) so batched loops vectorise; every
// select reproduces AeroBench's branch exactly, including its extrapolation beyond the tables.
#include "dynamics/engine_tables.hpp"
#include "dynamics/vector_math.hpp"

namespace f16race::dynamics {

struct AirData {
  double mach;      // [-]
  double qbar_psf;  // dynamic pressure [lbf/ft^2]
};

// Stevens & Lewis standard atmosphere (2nd ed., pp. 63-65), as in AeroBench adc.py.
F16_INLINE AirData air_data(double vt_ftps, double alt_ft) {
  constexpr double kRho0 = 2.377e-3;  // sea-level density [slug/ft^3]
  const double tfac = 1.0 - 0.703e-5 * alt_ft;
  const double temp_rankine = (alt_ft >= 35000.0) ? 390.0 : 519.0 * tfac;
  const double rho = kRho0 * vmath::pow_4_14(tfac);
  const double speed_of_sound = std::sqrt(1.4 * 1716.3 * temp_rankine);
  return {vt_ftps / speed_of_sound, 0.5 * rho * vt_ftps * vt_ftps};
}

// Throttle (0..1) to commanded power (0..100 %); the kink at 0.77 is the afterburner light-up.
F16_INLINE double throttle_gearing(double throttle) {
  return (throttle <= 0.77) ? 64.94 * throttle : 217.38 * throttle - 117.38;
}

// Reciprocal time constant of the power lag [1/s] for a power step dp.
F16_INLINE double power_lag_rate(double dp) {
  return (dp <= 25.0) ? 1.0 : ((dp >= 50.0) ? 0.1 : 1.9 - 0.036 * dp);
}

// d(pow)/dt for actual power `pow_pct` and commanded power `cmd_pct` (AeroBench pdot.py).
// Crossing military power (50 %) goes through the intermediate targets 60 % / 40 %.
F16_INLINE double power_derivative(double pow_pct, double cmd_pct) {
  const bool cmd_ab = cmd_pct >= 50.0;
  const bool pow_ab = pow_pct >= 50.0;
  const double target = cmd_ab ? (pow_ab ? cmd_pct : 60.0) : (pow_ab ? 40.0 : cmd_pct);
  const double rate = pow_ab ? 5.0 : power_lag_rate(target - pow_pct);
  return rate * (target - pow_pct);
}

// Engine thrust [lbf] from power, altitude and Mach by bilinear interpolation in the idle,
// military and maximum tables (AeroBench thrust.py), extrapolating past 50,000 ft and Mach 1.
F16_INLINE double engine_thrust(double pow_pct, double alt_ft, double mach) {
  const double alt = (alt_ft < 0.0) ? 0.01 : alt_ft;  // AeroBench's own clamp
  const double h = 0.0001 * alt;
  double i = std::trunc(h);
  i = (i < 4.0) ? i : 4.0;  // also catches NaN, so table reads stay in bounds
  i = (i > 0.0) ? i : 0.0;
  const double dh = h - i;
  const double rm = 5.0 * mach;
  double m = std::trunc(rm);
  m = (m < 4.0) ? m : 4.0;
  m = (m > 0.0) ? m : 0.0;
  const double dm = rm - m;
  const double cdh = 1.0 - dh;
  const int ii = static_cast<int>(i);
  const int mi = static_cast<int>(m);
  const int a = mi * 6 + ii;        // table[m][i]
  const int b = (mi + 1) * 6 + ii;  // table[m+1][i]
  using namespace tables;
  double s = kThrustTable[kThrustMil + a] * cdh + kThrustTable[kThrustMil + a + 1] * dh;
  double t = kThrustTable[kThrustMil + b] * cdh + kThrustTable[kThrustMil + b + 1] * dh;
  const double tmil = s + (t - s) * dm;
  // Below military power blend toward idle, above it toward maximum. The table is picked by
  // index rather than by branch so that no load sits inside a conditional (that blocks SIMD).
  const bool below_mil = pow_pct < 50.0;
  const int o = below_mil ? kThrustIdle : kThrustMax;
  s = kThrustTable[o + a] * cdh + kThrustTable[o + a + 1] * dh;
  t = kThrustTable[o + b] * cdh + kThrustTable[o + b + 1] * dh;
  const double tother = s + (t - s) * dm;
  return below_mil ? tother + (tmil - tother) * pow_pct * 0.02 : tmil + (tother - tmil) * (pow_pct - 50.0) * 0.02;
}

}  // namespace f16race::dynamics
