#pragma once
// An outer loop flown by a replay: what sets the inner loop's references (Nz, ps, Ny+r,
// throttle). AeroBench evaluates its autopilots inside the ODE right-hand side, at every RK
// stage, and changes their discrete mode only at output samples (run_f16_sim.py): u_ref() is
// the first, at_sample() the second. Recorded references (ReferenceSeries) are the outer loop
// without a mode.
#include <string>

#include "dynamics/state.hpp"

namespace f16race::dynamics {

class OuterLoop {
 public:
  virtual ~OuterLoop() = default;
  // References at time t for the stage state x. left_limit: the last stage of a step that ends
  // on a sample time (recorded references switch there; an autopilot's mode is frozen anyway).
  virtual RefVector u_ref(double t_s, const StateVector& x, bool left_limit) const = 0;
  // At the start time and every output sample, with the sampled state: the discrete update.
  virtual void at_sample(double /*t_s*/, const StateVector& /*x*/) {}
  // After at_sample: true stops the run with this sample as its last (AeroBench's
  // "autopilot finished").
  virtual bool finished(double /*t_s*/, const StateVector& /*x*/) const { return false; }
  // The current discrete mode as AeroBench names it ("roll", "Waypoint 2"); empty: none.
  virtual std::string mode() const { return {}; }
};

}  // namespace f16race::dynamics
