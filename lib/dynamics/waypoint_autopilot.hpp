#pragma once
// AeroBench's waypoint autopilot, native: heading (bank-to-turn toward the bearing of the current
// waypoint), altitude (Nz from the altitude error and climb rate, plus the level-turn load) and
// airspeed (throttle) tracking through a list of waypoints; a waypoint counts as reached inside
// 250 ft slant range; after the last it flies wings level at the last altitude and stops 5 s
// later. Transcribed from AeroBenchVVPython code/aerobench/examples/waypoint/waypoint_autopilot.py
// (commit afa9f0a, the commit of tests/data): gains, limits and switching rule; our own code.
#include <string>
#include <vector>

#include "dynamics/outer_loop.hpp"
#include "dynamics/state.hpp"

namespace f16race::dynamics {

// waypoint_autopilot.py lines 25-51, 108 and 185.
struct WaypointConstants {
  static constexpr double kSlantRangeThresholdFt = 250.0;  // reached when closer than this
  static constexpr double kKVt = 0.25;                     // throttle delta per ft/s below the set point
  static constexpr double kAirspeedFtps = 550.0;           // airspeed set point
  static constexpr double kKAlt = 0.005;                   // Nz per ft of altitude error
  static constexpr double kKHDot = 0.02;                   // Nz per ft/s of climb rate
  static constexpr double kKPropPsi = 5.0;                 // bank per rad of heading error
  static constexpr double kKDerPsi = 0.5;                  // bank per rad/s of yaw rate
  static constexpr double kKPropPhi = 0.75;                // ps per rad of bank error
  static constexpr double kKDerPhi = 0.5;                  // ps per rad/s of roll rate
  static constexpr double kMaxBankRad = 65.0 * 3.14159265358979323846 / 180.0;
  static constexpr double kMaxNzCmdG = 4.0;
  static constexpr double kMinNzCmdG = -1.0;
  static constexpr double kDescendBankRad = 15.0 * 3.14159265358979323846 / 180.0;  // no push in a bank beyond
  static constexpr double kDoneLingerS = 5.0;              // stop this long after the last waypoint
};

struct Waypoint {
  double n_ft = 0.0, e_ft = 0.0, alt_ft = 0.0;  // our state's order (AeroBench lists east first)
};

struct WaypointState {
  int index = 0;           // current waypoint; == size: done
  double done_s = 0.0;     // when the last waypoint was reached
};

// The references at state x flying toward waypoint w, holding airspeed_ftps (AeroBench: 550).
RefVector waypoint_u_ref_toward(const Waypoint& w, const double* x,
                                double airspeed_ftps = WaypointConstants::kAirspeedFtps);
// The references at state x while flying toward waypoints[index] (index < size), or, done,
// wings level at the last waypoint's altitude.
RefVector waypoint_u_ref(const std::vector<Waypoint>& waypoints, int index, const double* x);
// At an output sample: advance past a reached waypoint (at most one). True when it advanced.
bool waypoint_advance(const std::vector<Waypoint>& waypoints, WaypointState* state, double t_s, const double* x);
// AeroBench's stop rule: done, and more than 5 s since.
bool waypoint_finished(const std::vector<Waypoint>& waypoints, const WaypointState& state, double t_s);

class WaypointAutopilot final : public OuterLoop {
 public:
  // Throws std::invalid_argument on an empty list.
  explicit WaypointAutopilot(std::vector<Waypoint> waypoints);
  RefVector u_ref(double, const StateVector& x, bool) const override {
    return waypoint_u_ref(waypoints_, state_.index, x.data());
  }
  void at_sample(double t_s, const StateVector& x) override { waypoint_advance(waypoints_, &state_, t_s, x.data()); }
  bool finished(double t_s, const StateVector&) const override { return waypoint_finished(waypoints_, state_, t_s); }
  // "Waypoint k" (1-based) or "Done", as AeroBench names its modes.
  std::string mode() const override;
  const WaypointState& state() const { return state_; }

 private:
  std::vector<Waypoint> waypoints_;
  WaypointState state_;
};

}  // namespace f16race::dynamics
