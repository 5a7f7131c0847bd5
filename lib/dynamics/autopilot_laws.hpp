#pragma once
// The continuous part of AeroBench's two autopilots (what they command at a state, given their
// discrete mode), as inline functions of a state row: one definition used by the single-aircraft
// OuterLoop classes (gcas_autopilot.hpp, waypoint_autopilot.hpp) and by F16Batch at every RK
// stage of every lane. Constants and their sources are in those two headers.
#include <algorithm>
#include <cmath>

#include "dynamics/gcas_autopilot.hpp"
#include "dynamics/state.hpp"
#include "dynamics/vector_math.hpp"
#include "dynamics/waypoint_autopilot.hpp"

namespace f16race::dynamics::autopilot_law {

inline constexpr double kPi = 3.14159265358979323846;

// An angle minus its nearest multiple of 2π. Python's round() takes halves to even, as
// nearbyint does in the default rounding mode (std::round would take them away from zero).
F16_INLINE double wrap_nearest(double a) { return a - 2.0 * kPi * std::nearbyint(a / (2.0 * kPi)); }

// Into (−π, π] through a floored modulo, as Python's `a % 2π` then `-2π if > π`.
F16_INLINE double wrap_to_pi(double a) {
  double r = std::fmod(a, 2.0 * kPi);
  if (r < 0.0) r += 2.0 * kPi;
  return r > kPi ? r - 2.0 * kPi : r;
}

// GCAS (gcas_autopilot.py get_u_ref): roll: ps from the wings-level law; pull: Nz = 5 g;
// every other reference 0 (throttle: the trim's, a delta of 0). mode: a GcasMode.
F16_INLINE void gcas(GcasMode mode, const double* x, double* u) {
  using C = GcasConstants;
  u[kNzRef] = mode == GcasMode::kPull ? C::kNzDesG : 0.0;
  u[kPsRef] = mode == GcasMode::kRoll ? -wrap_nearest(x[kPhi]) * C::kKProp - x[kP] * C::kKDer : 0.0;
  u[kNyRRef] = 0.0;
  u[kThrottleDelta] = 0.0;
}

// Flight-path angle from the attitude and the aerodynamic angles (get_path_angle).
F16_INLINE double path_angle_rad(const double* x) {
  const double ca = std::cos(x[kAlpha]), sa = std::sin(x[kAlpha]), cb = std::cos(x[kBeta]), sb = std::sin(x[kBeta]);
  const double cp = std::cos(x[kPhi]), sp = std::sin(x[kPhi]), ct = std::cos(x[kTheta]), st = std::sin(x[kTheta]);
  return std::asin((ca * st - sa * ct * cp) * cb - (ct * sp) * sb);
}

F16_INLINE double waypoint_nz_altitude(double alt_cmd_ft, const double* x) {
  using C = WaypointConstants;
  const double h_dot_ftps = x[kVt] * std::sin(path_angle_rad(x));
  return C::kKAlt * (alt_cmd_ft - x[kAlt]) - C::kKHDot * h_dot_ftps;
}

// Roll-rate command toward a bank angle (φ itself is not wrapped, as in AeroBench).
F16_INLINE double waypoint_ps_for_bank(double phi_cmd_rad, const double* x) {
  using C = WaypointConstants;
  return C::kKPropPhi * (phi_cmd_rad - x[kPhi]) - C::kKDerPhi * x[kP];
}

F16_INLINE void waypoint_finish(double nz_g, double ps_radps, const double* x, double airspeed_ftps, double* u) {
  using C = WaypointConstants;
  u[kNzRef] = std::clamp(nz_g, C::kMinNzCmdG, C::kMaxNzCmdG);
  u[kPsRef] = ps_radps;
  u[kNyRRef] = 0.0;
  u[kThrottleDelta] = std::clamp(C::kKVt * (airspeed_ftps - x[kVt]), 0.0, 1.0);
}

// Waypoint autopilot flying toward (n_ft, e_ft, alt_ft) at airspeed_ftps (waypoint_autopilot.py
// get_u_ref in a 'Waypoint k' mode).
F16_INLINE void waypoint_toward(double n_ft, double e_ft, double alt_ft, double airspeed_ftps, const double* x,
                                double* u) {
  using C = WaypointConstants;
  // Bearing to the waypoint from north, clockwise (π/2 − atan2(ΔN, ΔE), wrapped).
  const double psi_cmd = wrap_to_pi(kPi / 2.0 - std::atan2(n_ft - x[kPn], e_ft - x[kPe]));
  const double psi_err = wrap_to_pi(psi_cmd - wrap_to_pi(x[kPsi]));
  const double phi_cmd = std::clamp(C::kKPropPsi * psi_err - C::kKDerPsi * x[kR], -C::kMaxBankRad, C::kMaxBankRad);
  // The load of a level turn, 1/cos φ − 1 (0 at φ = 0, as AeroBench's guard gives).
  const double nz_roll = x[kPhi] != 0.0 ? 1.0 / std::cos(x[kPhi]) - 1.0 : 0.0;
  const double nz = waypoint_nz_altitude(alt_ft, x) + nz_roll;
  // Descending in a bank of 15° or more: no pushing over (Nz floored at 0).
  const double nz_g = (alt_ft - x[kAlt] > 0.0 || std::fabs(x[kPhi]) < C::kDescendBankRad) ? nz : std::max(0.0, nz);
  waypoint_finish(nz_g, waypoint_ps_for_bank(phi_cmd, x), x, airspeed_ftps, u);
}

// After the last waypoint ('Done'): wings level at alt_ft (no turn term, no floor).
F16_INLINE void waypoint_done(double alt_ft, double airspeed_ftps, const double* x, double* u) {
  waypoint_finish(waypoint_nz_altitude(alt_ft, x), waypoint_ps_for_bank(0.0, x), x, airspeed_ftps, u);
}

}  // namespace f16race::dynamics::autopilot_law
