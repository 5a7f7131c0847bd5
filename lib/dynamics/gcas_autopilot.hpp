#pragma once
// AeroBench's ground-collision avoidance autopilot (GCAS), native: below the flight deck with the
// nose at or under the horizon it rolls wings level, then pulls 5 g until the nose is above the
// horizon for at least 2 s. Transcribed from AeroBenchVVPython
// code/aerobench/examples/gcas/gcas_autopilot.py (commit afa9f0a, the commit of tests/data):
// constants, predicates and the mode chain; our own code.
//
// The law (gcas_u_ref) is a pure function of a state row, so a batched loop can call it per
// lane; the mode lives in GcasState, advanced only at output samples as AeroBench does.
#include <string>

#include "dynamics/outer_loop.hpp"
#include "dynamics/state.hpp"

namespace f16race::dynamics {

enum class GcasMode { kStandby, kRoll, kPull, kWaiting };
const char* gcas_mode_name(GcasMode mode);                 // "standby", "roll", "pull", "waiting"
bool parse_gcas_mode(const std::string& text, GcasMode* out);

// gcas_autopilot.py lines 23-37 (angles converted with deg2rad as there).
struct GcasConstants {
  static constexpr double kEpsPhiRad = 5.0 * 3.14159265358979323846 / 180.0;   // wings level: |φ| below
  static constexpr double kEpsPRadps = 10.0 * 3.14159265358979323846 / 180.0;  // roll rate low: |p| below
  static constexpr double kPathGoalRad = 0.0;       // nose high enough: θ − α above
  static constexpr double kKProp = 4.0;             // roll law: ps = −k_prop φ − k_der p
  static constexpr double kKDer = 2.0;
  static constexpr double kFlightDeckFt = 1000.0;   // GCAS acts only below this altitude
  static constexpr double kMinPullTimeS = 2.0;
  static constexpr double kNzDesG = 5.0;            // pull-up Nz reference (zeroed at 1 g)
  static constexpr double kWaitingTimeS = 2.0;      // 'waiting' becomes 'roll' at this time
};

struct GcasState {
  GcasMode mode = GcasMode::kStandby;
  double pull_start_s = 0.0;
};

// References of the current mode at state x (every RK stage): roll: ps from the wings-level law,
// pull: Nz = 5 g; everything else 0 (throttle: the trim's, a delta of 0).
RefVector gcas_u_ref(GcasMode mode, const double* x);

// The discrete update at an output sample: at most one transition (the if/elif chain of
// advance_discrete_mode). Returns true when the mode changed.
bool gcas_advance(GcasState* state, double t_s, const double* x);

class GcasAutopilot final : public OuterLoop {
 public:
  explicit GcasAutopilot(GcasMode initial = GcasMode::kStandby) { state_.mode = initial; }
  RefVector u_ref(double, const StateVector& x, bool) const override { return gcas_u_ref(state_.mode, x.data()); }
  void at_sample(double t_s, const StateVector& x) override { gcas_advance(&state_, t_s, x.data()); }
  std::string mode() const override { return gcas_mode_name(state_.mode); }
  const GcasState& state() const { return state_; }

 private:
  GcasState state_;
};

}  // namespace f16race::dynamics
