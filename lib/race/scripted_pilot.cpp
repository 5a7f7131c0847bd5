#include "race/scripted_pilot.hpp"

#include <algorithm>
#include <cmath>

#include "dynamics/inner_loop.hpp"
#include "dynamics/physical_constants.hpp"
#include "dynamics/state.hpp"
#include "dynamics/waypoint_autopilot.hpp"

namespace f16race::race {

using namespace f16race::dynamics;

namespace {
// The point lookahead_ft ahead along the center-line, moved to lane_fraction of the aircraft's
// start offset in the tube's cross-section there.
// With a racing line, its offset there is added (and shift_up_frac of the radius upward), and the
// sum held within max_offset_frac of the radius: a lane near the wall plus the line's cut would aim
// outside the tube.
Vec3 lane_aim_point(const RaceEnv& env, int i, double lookahead_ft, double lane_fraction,
                    const TubeLine* line = nullptr, double max_offset_frac = 1.0, double shift_up_frac = 0.0) {
  const double s = env.progress_ft(i) + lookahead_ft;
  const TrackFrame fr = env.track(i / env.n_agent()).frame_at(s);
  double y = lane_fraction * env.start_lateral_ft(i), z = lane_fraction * env.start_vertical_ft(i);
  if (line || shift_up_frac != 0.0) {
    const TubeLine::Offset w = line ? line->offset_at(s) : TubeLine::Offset{};
    y += w.right_ft, z += w.up_ft + shift_up_frac * fr.radius_ft;
    const double r = std::sqrt(y * y + z * z), limit = max_offset_frac * fr.radius_ft;
    if (r > limit) y *= limit / r, z *= limit / r;
  }
  return fr.center + y * fr.right + z * fr.up;
}

// The point lookahead_ft ahead along the center-line, in the lane of aircraft i's HL goal: its
// offsets as fractions of the radius at the goal, applied to the radius at the aim point, so
// the aim stays inside the tube where it narrows.
Vec3 goal_lane_aim_point(const RaceEnv& env, int i, double lookahead_ft) {
  const Track& track = env.track(i / env.n_agent());
  const TrackFrame fr = track.frame_at(env.progress_ft(i) + lookahead_ft);
  const double k = fr.radius_ft / std::max(track.radius_at(env.goal_progress_ft(i)), 1.0);
  return fr.center + (k * env.goal_lateral_ft(i)) * fr.right + (k * env.goal_vertical_ft(i)) * fr.up;
}

// LL action entries in [-1, 1] from references (the inverse of RaceEnv's action mapping).
void write_action(const RaceConfig& c, double throttle, double nz_ref_g, double ps_ref_radps, float* a) {
  a[0] = static_cast<float>(2.0 * std::clamp(throttle, 0.0, 1.0) - 1.0);
  a[1] = static_cast<float>(std::clamp(2.0 * (nz_ref_g - c.nz_ref_min_g) / (c.nz_ref_max_g - c.nz_ref_min_g) - 1.0, -1.0, 1.0));
  a[2] = static_cast<float>(std::clamp(ps_ref_radps / std::max(c.ps_ref_max_radps, 1e-9), -1.0, 1.0));
}
}  // namespace

void scripted_actions(const RaceEnv& env, const ScriptedPilotConfig& k, float* actions, const std::int64_t* rows,
                      std::int64_t n_rows) {
  using dynamics::kG;
  using dynamics::kPi;
  const RaceConfig& c = env.config();
  const F16Batch& sim = env.sim();
  const std::int64_t n = rows ? n_rows : env.n_aircraft();
#pragma omp parallel for schedule(static)
  for (std::int64_t row = 0; row < n; ++row) {
    const int i = static_cast<int>(rows ? rows[row] : row);
    float* a = actions + static_cast<std::size_t>(i) * kActionDim;
    const Vec3 aim = lane_aim_point(env, i, k.lookahead_ft, k.lane_fraction);
    const Vec3 d = aim - Vec3{sim.state(kPn)[i], sim.state(kPe)[i], sim.state(kAlt)[i]};
    const double vt = sim.state(kVt)[i], phi = sim.state(kPhi)[i], theta = sim.state(kTheta)[i];
    const double psi = sim.state(kPsi)[i], alpha = sim.state(kAlpha)[i];
    double dpsi = std::atan2(d.e, d.n) - psi;
    dpsi = std::remainder(dpsi, 2.0 * kPi);
    const double gamma_cmd = std::atan2(d.u, std::sqrt(d.n * d.n + d.e * d.e));
    // Flight-path angle, approximately theta - alpha * cos(phi) for small sideslip.
    const double gamma = theta - alpha * std::cos(phi);
    const double bank_cmd = std::clamp(k.k_heading * dpsi, -k.max_bank_rad, k.max_bank_rad);
    const double ps_ref = std::clamp(k.k_bank * (bank_cmd - phi), -c.ps_ref_max_radps, c.ps_ref_max_radps);
    // Hold the turn (1/cos(bank) g) plus a pull proportional to the flight-path error.
    const double nz_ref = std::cos(gamma) / std::max(std::cos(phi), 0.3) - 1.0 + k.k_climb * (gamma_cmd - gamma) * vt / kG;
    const double throttle = std::clamp(0.35 + k.k_speed * (k.speed_ftps - vt), 0.0, 1.0);
    write_action(c, throttle, nz_ref, ps_ref, a);
  }
}

void autopilot_actions(const RaceEnv& env, const AutopilotPilotConfig& k, float* actions, const std::int64_t* rows,
                       std::int64_t n_rows) {
  const RaceConfig& c = env.config();
  const F16Batch& sim = env.sim();
  const std::int64_t n = rows ? n_rows : env.n_aircraft();
#pragma omp parallel for schedule(static)
  for (std::int64_t row = 0; row < n; ++row) {
    const int i = static_cast<int>(rows ? rows[row] : row);
    const Vec3 aim = k.follow_goal ? goal_lane_aim_point(env, i, k.lookahead_ft)
                                   : lane_aim_point(env, i, k.lookahead_ft, k.lane_fraction,
                                                    k.lines ? &(*k.lines)[i / env.n_agent()] : nullptr,
                                                    k.line_max_offset_frac, k.shift_up_frac);
    double x[kNumStates];
    for (int s = 0; s < kNumStates; ++s) x[s] = sim.state(s)[i];
    // One waypoint, always ahead: AeroBench's law as it flies toward its current waypoint.
    const RefVector u = waypoint_u_ref_toward(dynamics::Waypoint{aim.n, aim.e, aim.u}, x, k.airspeed_ftps);
    // AeroBench's throttle is a delta on its trim throttle; the race's action is the throttle.
    write_action(c, lqr::kThrottleEquil + u[kThrottleDelta], u[kNzRef], u[kPsRef],
                 actions + static_cast<std::size_t>(i) * kActionDim);
  }
}

}  // namespace f16race::race
