// Starting races: every env at once, one env on a named stream, or an env whose race just ended.
// Each race gets a fresh track from its env's random stream and its aircraft start in level trim
// in a disc at the start line, their goals in the middle bins until the HL policy decides.
#include <algorithm>
#include <cmath>

#include "dynamics/inner_loop.hpp"
#include "dynamics/physical_constants.hpp"
#include "race/race_env.hpp"

namespace f16race::race {

using namespace f16race::dynamics;

void RaceEnv::reset() {
#pragma omp parallel for schedule(static)
  for (int e = 0; e < n_env(); ++e) {
    reset_env(e);
    env_done_[e] = 0;
    write_observations(e);
  }
}

void RaceEnv::start_race(int env, std::uint64_t stream_id) {
  rng_[env] = RandomStream(config_.seed, stream_id);
  reset_env(env);
  write_observations(env);
}

void RaceEnv::reseed_streams(std::uint64_t salt) {
  for (int e = 0; e < n_env(); ++e)
    rng_[e] = RandomStream(config_.seed, (salt << 32) + static_cast<std::uint64_t>(first_env_id_ + e));
}

void RaceEnv::reset_env(int env) {
  RandomStream& rng = rng_[env];
  tracks_[env] = Track::generate(config_.track, rng);
  compute_racing_line(env);
  const Track& tr = tracks_[env];
  time_s_[env] = 0.0;
  hl_time_left_s_[env] = 0.0;
  hl_due_[env] = 1;
  const TrackFrame fr = tr.frame_at(config_.start_s_ft);
  const double heading = std::atan2(fr.tangent.e, fr.tangent.n);
  const double max_off = config_.start_offset_frac * fr.radius_ft;
  const int base = env * n_agent_;
  for (int a = 0; a < n_agent_; ++a) {
    const int i = base + a;
    // Uniform in the disc, re-drawn (a bounded number of times) if too close to another aircraft.
    double lat = 0.0, vert = 0.0;
    for (int attempt = 0; attempt < 64; ++attempt) {
      const double r = max_off * std::sqrt(rng.uniform()), ang = rng.uniform(0.0, 2.0 * kPi);
      lat = r * std::cos(ang);
      vert = r * std::sin(ang);
      bool clear = true;
      for (int b = 0; b < a; ++b) {
        const double dl = lat - start_lateral_ft_[base + b], dv = vert - start_vertical_ft_[base + b];
        clear = clear && dl * dl + dv * dv >= config_.start_min_separation_ft * config_.start_min_separation_ft;
      }
      if (clear) break;
    }
    const Vec3 p = fr.center + lat * fr.right + vert * fr.up;
    const int k = std::clamp(static_cast<int>(std::lround((p.u - trim_alt0_ft_) / trim_step_ft_)), 0,
                             static_cast<int>(trims_.size()) - 1);
    const TrimResult& trim = trims_[k];
    StateVector x = trim.x0;
    x[kPn] = p.n;
    x[kPe] = p.e;
    x[kPsi] = heading;  // x[kAlt] is the trim grid altitude, within trim_step/2 of p.u
    sim_.reset_aircraft(i, x, trim.u_ref);
    start_lateral_ft_[i] = lat;
    start_vertical_ft_[i] = vert;
    alive_[i] = 1;
    cause_[i] = kCauseNone;
    tube_out_s_[i] = 0.0;
    // Warm start at the start line: a cold (global) search per aircraft and reset cost more
    // than the rest of the reset, and the start point's nearest sample is known.
    track_hint_[i] = std::clamp(static_cast<int>(config_.start_s_ft / tr.spacing_ft()), 0, tr.n_samples() - 1);
    // The trim's own commands, in action units, are the "previous action" of the first step.
    const auto trim_a = action_of(trim);
    std::copy(trim_a.begin(), trim_a.end(), &prev_action_[static_cast<std::size_t>(i) * kActionDim]);
  }
  // Velocities and Nz of the new race's first observation come from the outputs: evaluated here,
  // they would otherwise be the ended race's (or zeros in a new env).
  sim_.evaluate_outputs(base, n_agent_);
  update_track_geometry(env);
  compute_ranks(env);
  for (int a = 0; a < n_agent_; ++a) {
    const int i = base + a;
    prev_ego_rank_[i] = ego_rank_[i];
    const std::int64_t mid[3] = {config_.hl_center_bin(), config_.hl_center_bin(), config_.hl_center_bin()};
    place_goal(i, mid);  // until the HL policy decides (hl_due is up)
  }
  separate_goals(env, -1);
}

std::array<float, kActionDim> RaceEnv::action_of(const TrimResult& trim) const {
  return {static_cast<float>(2.0 * (trim.u_ref[kThrottleDelta] + lqr::kThrottleEquil) - 1.0),
          static_cast<float>(2.0 * (trim.u_ref[kNzRef] - config_.nz_ref_min_g) /
                                 (config_.nz_ref_max_g - config_.nz_ref_min_g) - 1.0),
          0.0f};
}

}  // namespace f16race::race
