#include "dynamics/waypoint_autopilot.hpp"

#include <algorithm>
#include <cmath>
#include <stdexcept>
#include <utility>

namespace f16race::dynamics {
namespace {

constexpr double kPi = 3.14159265358979323846;
using C = WaypointConstants;

// Into (−π, π] through a floored modulo, as Python's `a % 2π` then `-2π if > π`.
double wrap_to_pi(double a) {
  double r = std::fmod(a, 2.0 * kPi);
  if (r < 0.0) r += 2.0 * kPi;
  return r > kPi ? r - 2.0 * kPi : r;
}

// Flight-path angle from the attitude and the aerodynamic angles (get_path_angle).
double path_angle_rad(const double* x) {
  const double ca = std::cos(x[kAlpha]), sa = std::sin(x[kAlpha]), cb = std::cos(x[kBeta]), sb = std::sin(x[kBeta]);
  const double cp = std::cos(x[kPhi]), sp = std::sin(x[kPhi]), ct = std::cos(x[kTheta]), st = std::sin(x[kTheta]);
  return std::asin((ca * st - sa * ct * cp) * cb - (ct * sp) * sb);
}

double nz_altitude(double alt_cmd_ft, const double* x) {
  const double h_dot_ftps = x[kVt] * std::sin(path_angle_rad(x));
  return C::kKAlt * (alt_cmd_ft - x[kAlt]) - C::kKHDot * h_dot_ftps;
}

// Roll-rate command toward a bank angle (φ itself is not wrapped, as in AeroBench).
double ps_for_bank(double phi_cmd_rad, const double* x) {
  return C::kKPropPhi * (phi_cmd_rad - x[kPhi]) - C::kKDerPhi * x[kP];
}

}  // namespace

namespace {
RefVector finish_refs(double nz_g, double ps_radps, const double* x, double airspeed_ftps) {
  RefVector u{};
  u[kNzRef] = std::clamp(nz_g, C::kMinNzCmdG, C::kMaxNzCmdG);
  u[kPsRef] = ps_radps;
  u[kNyRRef] = 0.0;
  u[kThrottleDelta] = std::clamp(C::kKVt * (airspeed_ftps - x[kVt]), 0.0, 1.0);
  return u;
}
}  // namespace

RefVector waypoint_u_ref_toward(const Waypoint& w, const double* x, double airspeed_ftps) {
  // Bearing to the waypoint from north, clockwise (π/2 − atan2(ΔN, ΔE), wrapped).
  const double psi_cmd = wrap_to_pi(kPi / 2.0 - std::atan2(w.n_ft - x[kPn], w.e_ft - x[kPe]));
  const double psi_err = wrap_to_pi(psi_cmd - wrap_to_pi(x[kPsi]));
  const double phi_cmd = std::clamp(C::kKPropPsi * psi_err - C::kKDerPsi * x[kR], -C::kMaxBankRad, C::kMaxBankRad);
  // The load of a level turn, 1/cos φ − 1 (0 at φ = 0, as AeroBench's guard gives).
  const double nz_roll = x[kPhi] != 0.0 ? 1.0 / std::cos(x[kPhi]) - 1.0 : 0.0;
  const double nz = nz_altitude(w.alt_ft, x) + nz_roll;
  // Descending in a bank of 15° or more: no pushing over (Nz floored at 0).
  const double nz_g = (w.alt_ft - x[kAlt] > 0.0 || std::fabs(x[kPhi]) < C::kDescendBankRad) ? nz : std::max(0.0, nz);
  return finish_refs(nz_g, ps_for_bank(phi_cmd, x), x, airspeed_ftps);
}

RefVector waypoint_u_ref(const std::vector<Waypoint>& wps, int index, const double* x) {
  if (index < static_cast<int>(wps.size())) return waypoint_u_ref_toward(wps[static_cast<std::size_t>(index)], x);
  // Done: wings level at the last waypoint's altitude (no turn term, no floor).
  return finish_refs(nz_altitude(wps.back().alt_ft, x), ps_for_bank(0.0, x), x, C::kAirspeedFtps);
}

bool waypoint_advance(const std::vector<Waypoint>& wps, WaypointState* s, double t_s, const double* x) {
  const int n = static_cast<int>(wps.size());
  if (s->index >= n) return false;
  const Waypoint& w = wps[static_cast<std::size_t>(s->index)];
  const double dn = w.n_ft - x[kPn], de = w.e_ft - x[kPe], dh = w.alt_ft - x[kAlt];
  if (std::sqrt(de * de + dn * dn + dh * dh) >= C::kSlantRangeThresholdFt) return false;
  if (++s->index >= n) s->done_s = t_s;
  return true;
}

bool waypoint_finished(const std::vector<Waypoint>& wps, const WaypointState& s, double t_s) {
  return s.index >= static_cast<int>(wps.size()) && s.done_s + C::kDoneLingerS < t_s;
}

WaypointAutopilot::WaypointAutopilot(std::vector<Waypoint> waypoints) : waypoints_(std::move(waypoints)) {
  if (waypoints_.empty()) throw std::invalid_argument("the waypoint autopilot needs at least one waypoint");
}

std::string WaypointAutopilot::mode() const {
  return state_.index >= static_cast<int>(waypoints_.size()) ? "Done" : "Waypoint " + std::to_string(state_.index + 1);
}

}  // namespace f16race::dynamics
