#include "race/terminations.hpp"

#include <cmath>

#include "dynamics/physical_constants.hpp"
#include "dynamics/vector_math.hpp"
#include "race/aircraft_state.hpp"
#include "race/race_env.hpp"

namespace f16race::race {

using namespace f16race::dynamics;

const char* cause_name(int cause) {
  switch (cause) {
    case kCauseNone: return "none";
    case kCauseCollision: return "collision";
    case kCauseAltitude: return "altitude";
    case kCauseLoad: return "load";
    case kCauseTurnRate: return "turn_rate";
    case kCauseTube: return "tube";
    case kCauseSimulator: return "simulator";
    case kCauseTeamCollision: return "team_collision";
    case kCauseEnvelope: return "envelope";
    default: return "unknown";
  }
}

void find_terminations(const RaceConfig& c, const F16Batch& sim, int base, int n_agent, const std::uint8_t* alive,
                       const double* dist_ft, const double* radius_ft, double* tube_out_s, std::int8_t* cause) {
  // The attitude trig of the turn rate, for the env's aircraft in one vector pass.
  double sphi[16], cphi[16], sth[16], cth[16];
  const double* phi = sim.state(kPhi) + base;
  const double* theta = sim.state(kTheta) + base;
#pragma omp simd
  for (int a = 0; a < n_agent; ++a) {
    vmath::sincos(phi[a], &sphi[a], &cphi[a]);
    vmath::sincos(theta[a], &sth[a], &cth[a]);
  }
  for (int a = 0; a < n_agent; ++a) {
    const int i = base + a;
    if (!alive[a]) continue;
    const double psi_dot = (sim.state(kQ)[i] * sphi[a] + sim.state(kR)[i] * cphi[a]) / cth[a];
    const double nz = sim.output(kOutNz)[i];
    const double alt = sim.state(kAlt)[i];
    const bool outside = dist_ft[a] > radius_ft[a];
    tube_out_s[a] = outside ? tube_out_s[a] + c.dt_ll_s : 0.0;
    std::int8_t k = kCauseNone;
    if (sim.status()[i] != kStatusOk) k = kCauseSimulator;
    else if (alt < c.alt_min_ft || alt > c.alt_max_ft) k = kCauseAltitude;
    else if (nz < c.nz_min_g || nz > c.nz_max_g) k = kCauseLoad;
    else if (std::fabs(psi_dot) * 180.0 / kPi > c.turn_rate_max_dps) k = kCauseTurnRate;
    else if (outside && (c.tube_exit == TubeExit::kTerminate || tube_out_s[a] > c.tube_grace_s)) k = kCauseTube;
    else if (c.mach_max > 0.0 && aircraft_mach(sim, i) > c.mach_max) k = kCauseEnvelope;
    cause[a] = k;
  }
}

// The step's causes take their aircraft out: frozen where they were, counted in the env's stats.
void RaceEnv::take_out(int env, const std::int8_t* new_cause) {
  const int base = env * n_agent_;
  for (int a = 0; a < n_agent_; ++a) {
    const int i = base + a;
    if (new_cause[a] == kCauseNone) continue;
    alive_[i] = 0;
    cause_[i] = new_cause[a];
    step_cause_[i] = new_cause[a];
    terminated_[i] = 1;
    step_stats_[env].terminations[new_cause[a]] += 1;
    sim_.status()[i] = kStatusRetired;  // frozen where it was taken out
  }
}

}  // namespace f16race::race
