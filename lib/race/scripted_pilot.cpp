#include "race/scripted_pilot.hpp"

#include <algorithm>
#include <cmath>

#include "dynamics/physical_constants.hpp"
#include "dynamics/state.hpp"

namespace f16race::race {

using namespace f16race::dynamics;

void scripted_actions(const RaceEnv& env, const ScriptedPilotConfig& k, float* actions) {
  using dynamics::kG;
  using dynamics::kPi;
  const RaceConfig& c = env.config();
  const F16Batch& sim = env.sim();
#pragma omp parallel for schedule(static)
  for (int i = 0; i < env.n_aircraft(); ++i) {
    float* a = actions + static_cast<std::size_t>(i) * kActionDim;
    const TrackFrame fr = env.track(i / env.n_agent()).frame_at(env.progress_ft(i) + k.lookahead_ft);
    const Vec3 aim = fr.center + (k.lane_fraction * env.start_lateral_ft(i)) * fr.right +
                     (k.lane_fraction * env.start_vertical_ft(i)) * fr.up;
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
    a[0] = static_cast<float>(2.0 * throttle - 1.0);
    a[1] = static_cast<float>(std::clamp(2.0 * (nz_ref - c.nz_ref_min_g) / (c.nz_ref_max_g - c.nz_ref_min_g) - 1.0, -1.0, 1.0));
    a[2] = static_cast<float>(ps_ref / std::max(c.ps_ref_max_radps, 1e-9));
  }
}

}  // namespace f16race::race
