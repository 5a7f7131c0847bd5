#include "dynamics/waypoint_autopilot.hpp"

#include <cmath>
#include <stdexcept>
#include <utility>

#include "dynamics/autopilot_laws.hpp"

namespace f16race::dynamics {

RefVector waypoint_u_ref_toward(const Waypoint& w, const double* x, double airspeed_ftps) {
  RefVector u;
  autopilot_law::waypoint_toward(w.n_ft, w.e_ft, w.alt_ft, airspeed_ftps, x, u.data());
  return u;
}

RefVector waypoint_u_ref(const std::vector<Waypoint>& wps, int index, const double* x) {
  if (index < static_cast<int>(wps.size())) return waypoint_u_ref_toward(wps[static_cast<std::size_t>(index)], x);
  RefVector u;
  autopilot_law::waypoint_done(wps.back().alt_ft, WaypointConstants::kAirspeedFtps, x, u.data());
  return u;
}

bool waypoint_advance(const std::vector<Waypoint>& wps, WaypointState* s, double t_s, const double* x) {
  const int n = static_cast<int>(wps.size());
  if (s->index >= n) return false;
  const Waypoint& w = wps[static_cast<std::size_t>(s->index)];
  const double dn = w.n_ft - x[kPn], de = w.e_ft - x[kPe], dh = w.alt_ft - x[kAlt];
  if (std::sqrt(de * de + dn * dn + dh * dh) >= WaypointConstants::kSlantRangeThresholdFt) return false;
  if (++s->index >= n) s->done_s = t_s;
  return true;
}

bool waypoint_finished(const std::vector<Waypoint>& wps, const WaypointState& s, double t_s) {
  return s.index >= static_cast<int>(wps.size()) && s.done_s + WaypointConstants::kDoneLingerS < t_s;
}

WaypointAutopilot::WaypointAutopilot(std::vector<Waypoint> waypoints) : waypoints_(std::move(waypoints)) {
  if (waypoints_.empty()) throw std::invalid_argument("the waypoint autopilot needs at least one waypoint");
}

std::string WaypointAutopilot::mode() const {
  return state_.index >= static_cast<int>(waypoints_.size()) ? "Done" : "Waypoint " + std::to_string(state_.index + 1);
}

}  // namespace f16race::dynamics
