#pragma once
// Wings-level, constant-altitude trim of the closed-loop F-16, the start condition of the
// AeroBench reference scenarios and of every race.
#include <stdexcept>
#include <string>

#include "dynamics/state.hpp"

namespace f16race::dynamics {

// No level trim at the requested speed and altitude: a request the caller can change, so the
// callers turn it into their user-facing error with the option or key it came from.
class TrimError : public std::runtime_error {
 public:
  using std::runtime_error::runtime_error;
};

struct TrimRequest {
  AeroModel model = AeroModel::kMorelli;
  double vt_ftps = 540.0;
  double alt_ft = 5000.0;
  double psi_rad = 0.0;  // heading; trim does not depend on it
};

struct TrimResult {
  double alpha_rad = 0.0;       // = theta (level flight)
  double elevator_deg = 0.0;
  double throttle = 0.0;
  double residual = 0.0;        // max |d(vt)|, |d(alpha)|, |d(q)| at the solution
  StateVector x0{};             // 16 states with pow = tgear(throttle) and the Nz integrator preloaded
  RefVector u_ref{};            // [cos(theta) - 1, 0, 0, throttle - 0.1395]: holds the trim
};

// Solves d(vt) = d(alpha) = d(q) = 0 for (alpha, elevator, throttle) by Newton's method on the
// plant, then preloads int_e_Nz so that the LQR elevator equals the trim elevator, as the
// reference README describes. Throws TrimError naming the request when no trim exists
// (e.g. too slow to fly level, or beyond full afterburner).
TrimResult trim_level_flight(const TrimRequest& request);

}  // namespace f16race::dynamics
