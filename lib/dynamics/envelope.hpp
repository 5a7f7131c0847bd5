#pragma once
// Per-aircraft health: the envelope in which the model is trusted and the status codes of a
// frozen aircraft. Shared by the batched simulator and the single-aircraft replay.
#include <cfloat>
#include <cmath>
#include <cstdint>

#include "dynamics/physical_constants.hpp"
#include "dynamics/state.hpp"
#include "dynamics/vector_math.hpp"

namespace f16race::dynamics {

// Why an aircraft is frozen. kOk aircraft are integrated; any other value freezes the aircraft
// at its last valid state until the owner resets it.
enum AircraftStatus : std::int32_t {
  kStatusOk = 0,
  kStatusNonFinite = 1,   // a state became NaN or infinite
  kStatusAlpha = 2,       // angle of attack left the model's table range
  kStatusBeta = 3,        // sideslip too large
  kStatusTheta = 4,       // pitch too close to +-90 deg (Euler-angle singularity)
  kStatusSpeed = 5,       // airspeed outside the model's range
  kStatusAltitude = 6,    // altitude outside the atmosphere model's range
  kStatusPadding = 7,     // not an aircraft: lanes that round the batch up to whole blocks
  kStatusRetired = 8,     // taken out by the owner (e.g. the race ended it for this aircraft)
};
const char* status_name(std::int32_t status);

// Envelope in which the aero tables and kinematics are trusted; leaving it freezes the aircraft.
struct EnvelopeLimits {
  double alpha_min_rad = -10.0 * kDegToRad;  // Stevens tables start at -10 deg
  double alpha_max_rad = 45.0 * kDegToRad;   // and end at 45 deg
  double beta_max_rad = 30.0 * kDegToRad;
  double theta_max_rad = 85.0 * kDegToRad;   // psi-dot ~ 1/cos(theta)
  double vt_min_ftps = 50.0;
  double vt_max_ftps = 3000.0;
  double alt_min_ft = -10000.0;
  double alt_max_ft = 100000.0;  // the density fit and thrust extrapolation end around here
};

// Status a freshly integrated state earns; NaN/inf outranks the envelope checks. Written as a
// chain of selects without && or ||: short-circuit control flow stops GCC vectorising the lane.
F16_INLINE std::int32_t classify_state(const double* x, const EnvelopeLimits& lim) {
  double non_finite = 0.0;
#pragma GCC unroll 16
  for (int s = 0; s < kNumStates; ++s) non_finite = (std::fabs(x[s]) <= DBL_MAX) ? non_finite : 1.0;
  std::int32_t code = kStatusOk;
  code = ((x[kAlt] >= lim.alt_min_ft) & (x[kAlt] <= lim.alt_max_ft)) ? code : kStatusAltitude;
  code = ((x[kVt] >= lim.vt_min_ftps) & (x[kVt] <= lim.vt_max_ftps)) ? code : kStatusSpeed;
  code = (std::fabs(x[kTheta]) <= lim.theta_max_rad) ? code : kStatusTheta;
  code = (std::fabs(x[kBeta]) <= lim.beta_max_rad) ? code : kStatusBeta;
  code = ((x[kAlpha] >= lim.alpha_min_rad) & (x[kAlpha] <= lim.alpha_max_rad)) ? code : kStatusAlpha;
  code = (non_finite == 0.0) ? code : kStatusNonFinite;
  return code;
}

// The domain a start state read from a file must lie in before it is flown: every state finite,
// the envelope above (the aero tables' alpha range, sideslip, pitch, airspeed, altitude) and the
// engine's power state 0..100 %. Returns the first state outside it, or -1; `lo` and `hi` get
// that state's allowed range (for |beta| and |theta| the signed one). Input validation only: the
// simulator itself freezes an aircraft that leaves the envelope (classify_state).
inline int first_state_outside_domain(const StateVector& x, const EnvelopeLimits& lim, double* lo, double* hi) {
  const double big = DBL_MAX;
  auto bounds = [&](int s, double& l, double& h) {
    switch (s) {
      case kVt: l = lim.vt_min_ftps, h = lim.vt_max_ftps; break;
      case kAlpha: l = lim.alpha_min_rad, h = lim.alpha_max_rad; break;
      case kBeta: l = -lim.beta_max_rad, h = lim.beta_max_rad; break;
      case kTheta: l = -lim.theta_max_rad, h = lim.theta_max_rad; break;
      case kAlt: l = lim.alt_min_ft, h = lim.alt_max_ft; break;
      case kPow: l = 0.0, h = 100.0; break;
      default: l = -big, h = big;
    }
  };
  for (int s = 0; s < kNumStates; ++s) {
    double l, h;
    bounds(s, l, h);
    if (!(x[s] >= l && x[s] <= h)) {  // NaN fails both
      *lo = l;
      *hi = h;
      return s;
    }
  }
  return -1;
}

}  // namespace f16race::dynamics
