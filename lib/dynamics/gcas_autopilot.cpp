#include "dynamics/gcas_autopilot.hpp"

#include <cmath>

#include "dynamics/autopilot_laws.hpp"

namespace f16race::dynamics {
namespace {

using C = GcasConstants;
using autopilot_law::wrap_nearest;

bool wings_level(const double* x) { return std::fabs(wrap_nearest(x[kPhi])) < C::kEpsPhiRad; }
bool roll_rate_low(const double* x) { return std::fabs(x[kP]) < C::kEpsPRadps; }
bool above_flight_deck(const double* x) { return x[kAlt] >= C::kFlightDeckFt; }
bool nose_high_enough(const double* x) { return wrap_nearest(x[kTheta] - x[kAlpha]) > C::kPathGoalRad; }

}  // namespace

const char* gcas_mode_name(GcasMode mode) {
  switch (mode) {
    case GcasMode::kStandby: return "standby";
    case GcasMode::kRoll: return "roll";
    case GcasMode::kPull: return "pull";
    case GcasMode::kWaiting: return "waiting";
  }
  return "unknown";
}

bool parse_gcas_mode(const std::string& text, GcasMode* out) {
  for (GcasMode m : {GcasMode::kStandby, GcasMode::kRoll, GcasMode::kPull, GcasMode::kWaiting})
    if (text == gcas_mode_name(m)) {
      *out = m;
      return true;
    }
  return false;
}

RefVector gcas_u_ref(GcasMode mode, const double* x) {
  RefVector u;
  autopilot_law::gcas(mode, x, u.data());
  return u;
}

bool gcas_advance(GcasState* s, double t_s, const double* x) {
  const GcasMode before = s->mode;
  switch (s->mode) {
    case GcasMode::kWaiting:
      if (t_s + 1e-6 >= C::kWaitingTimeS) s->mode = GcasMode::kRoll;  // the 1e-6 is AeroBench's
      break;
    case GcasMode::kStandby:
      if (!nose_high_enough(x) && !above_flight_deck(x)) s->mode = GcasMode::kRoll;
      break;
    case GcasMode::kRoll:
      if (roll_rate_low(x) && wings_level(x)) {
        s->mode = GcasMode::kPull;
        s->pull_start_s = t_s;
      }
      break;
    case GcasMode::kPull:
      if (nose_high_enough(x) && t_s >= s->pull_start_s + C::kMinPullTimeS) s->mode = GcasMode::kStandby;
      break;
  }
  return s->mode != before;
}

}  // namespace f16race::dynamics
