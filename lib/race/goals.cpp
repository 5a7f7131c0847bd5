// The HL goals: placed from the HL bins at a decision (and again at the horizon when reached),
// kept apart across the track between teammates.
#include <algorithm>
#include <cmath>

#include "dynamics/physical_constants.hpp"
#include "race/aircraft_state.hpp"
#include "race/race_env.hpp"

namespace f16race::race {

using dynamics::kPi;

namespace {
// `off` with its cross-track part (across the tangent of `fr`) clipped to `limit`.
Vec3 clip_across(Vec3 off, const TrackFrame& fr, double limit) {
  const Vec3 along = dot(off, fr.tangent) * fr.tangent, cross = off - along;
  const double c = norm(cross);
  return c > limit ? along + (limit / c) * cross : off;
}
}  // namespace

void RaceEnv::place_goal(int i, const std::int64_t* bins) {
  const int env = i / n_agent_;
  goal_progress_ft_[i] = progress_ft_[i] + config_.goal_ahead();
  for (int k = 0; k < kHlDims; ++k)  // clamped as the offsets below are
    goal_bins_[static_cast<std::size_t>(i) * kHlDims + k] = std::clamp<std::int64_t>(bins[k], 0, config_.hl_bins - 1);
  const TrackFrame fr = tracks_[env].frame_at(goal_progress_ft_[i]);
  const double half = 0.5 * (config_.hl_bins - 1);
  const double step = half > 0 ? config_.goal_bin_scale * fr.radius_ft / half : 0.0;
  auto offset = [&](std::int64_t b) {
    const double bb = std::clamp(static_cast<double>(b), 0.0, static_cast<double>(config_.hl_bins - 1));
    return (bb - half) * step;
  };
  // Offsets along north, east and up (the paper's d_pn, d_pe, d_pa), or along the track frame at
  // the goal (tangent, right, up). A corner bin would sit sqrt(3) x further out than an axis
  // bin, so the cross-track part is clipped to the outer bin's radius: every goal the HL can
  // choose lies inside the tube.
  Vec3 off{offset(bins[0]), offset(bins[1]), offset(bins[2])};
  if (config_.goal_frame == GoalFrame::kTrack) off = off.n * fr.tangent + off.e * fr.right + off.u * fr.up;
  const double limit = config_.goal_bin_scale * fr.radius_ft;
  off = clip_across(off, fr, limit);
  if (!lines_.empty()) {  // the bins around the racing line, the goal still inside the outer bins' radius
    const TubeLine::Offset w = lines_[env].offset_at(goal_progress_ft_[i]);
    off = clip_across(off + w.right_ft * fr.right + w.up_ft * fr.up, fr, limit);
  }
  if (config_.goal_shift_up_frac != 0.0)
    off = clip_across(off + (config_.goal_shift_up_frac * fr.radius_ft) * fr.up, fr, limit);
  goal_point_[i] = fr.center + off;
  goal_lateral_ft_[i] = dot(off, fr.right);
  goal_vertical_ft_[i] = dot(off, fr.up);
  goal_dist_ft_[i] = norm(goal_point_[i] - aircraft_position(sim_, i));
}

void RaceEnv::goal_lane_here(int i, double* right_ft, double* up_ft) const {
  TubeLine::Offset at_goal, here;  // the line's offsets (zero without a line)
  if (!lines_.empty()) {
    const TubeLine& line = lines_[i / n_agent_];
    at_goal = line.offset_at(goal_progress_ft_[i]);
    here = line.offset_at(progress_ft_[i]);
  }
  // The goal's offset from the line in feet, as placed, carried along the line (keeping it as a
  // fraction of the local radius instead was measured and not adopted).
  *right_ft = goal_lateral_ft_[i] + (here.right_ft - at_goal.right_ft);
  *up_ft = goal_vertical_ft_[i] + (here.up_ft - at_goal.up_ft);
}

// Once per race, not per step; the solver's few kilobytes of vectors are the one allocation a
// reset makes.
void RaceEnv::compute_racing_line(int env) {
  if (config_.goal_line_frac <= 0.0) return;
  const Track& tr = tracks_[env];
  TubeLineInputs in;
  in.s0_ft = config_.start_s_ft;
  in.s1_ft = tr.length_ft() - config_.finish_margin_ft;
  in.inset_frac = 1.0 - config_.goal_line_frac;
  // Within ~3 ft of the converged line in 0.4 ms a race (1e-5 ft: 10 ms, as many as ~300 LL steps).
  in.tolerance_ft = 0.01;
  lines_[env] = shortest_tube_line(tr, in);
}

void RaceEnv::set_hl_actions(const std::int64_t* bins) {
#pragma omp parallel for schedule(static)
  for (int e = 0; e < n_env(); ++e) {
    if (!hl_due_[e]) continue;
    for (int a = 0; a < n_agent_; ++a) {
      const int i = e * n_agent_ + a;
      if (alive_[i]) place_goal(i, bins + static_cast<std::size_t>(i) * kHlDims);
    }
    separate_goals(e, -1);
    for (int a = 0; a < n_agent_; ++a) write_goal_observation(e * n_agent_ + a);
    hl_due_[e] = 0;
    hl_time_left_s_[e] = config_.dt_hl_s;
    for (int a = 0; a < n_agent_; ++a)  // the task entry "time to the next HL decision"
      task_[static_cast<std::size_t>(e * n_agent_ + a) * task_dim_ + kPreviewWidth * config_.preview_points +
            kTaskHlTimeLeft] = 1.0f;
  }
}

// A goal the aircraft has (nearly) reached is placed again at the horizon with the same bins:
// the decision holds for the whole HL interval, whatever its length. The placement resets the
// distance the progress reward is measured from, so the jump itself pays nothing.
void RaceEnv::refresh_reached_goals(int env) {
  const RaceConfig& c = config_;
  if (c.goal_refresh_ft <= 0.0) return;
  for (int a = 0; a < n_agent_; ++a) {
    const int i = env * n_agent_ + a;
    if (alive_[i] && progress_ft_[i] + c.goal_refresh_ft >= goal_progress_ft_[i]) {
      place_goal(i, &goal_bins_[static_cast<std::size_t>(i) * kHlDims]);
      separate_goals(env, i);  // the teammates keep their goals: only the new one moves
    }
  }
}

void RaceEnv::shift_goal(int i, double right_ft, double up_ft) {
  const TrackFrame fr = tracks_[i / n_agent_].frame_at(goal_progress_ft_[i]);
  // At the outer bins' radius the best it can do.
  const Vec3 off = clip_across(goal_point_[i] - fr.center + right_ft * fr.right + up_ft * fr.up, fr,
                               config_.goal_bin_scale * fr.radius_ft);
  goal_point_[i] = fr.center + off;
  goal_lateral_ft_[i] = dot(off, fr.right);
  goal_vertical_ft_[i] = dot(off, fr.up);
  goal_dist_ft_[i] = norm(goal_point_[i] - aircraft_position(sim_, i));  // the progress reward counts from the moved goal
}

void RaceEnv::separate_goals(int env, int mover) {
  const double sep = config_.goal_min_separation_ft;
  if (sep <= 0.0) return;
  const int ts = config_.team_size;
  // Pairwise relaxation: each close pair parts across the track by the shortfall, half each (all
  // of it for `mover`); a few sweeps settle a team of four.
  for (int sweep = 0; sweep < 16; ++sweep) {
    bool moved = false;
    for (int a = 0; a < n_agent_; ++a)
      for (int b = a + 1; b < n_agent_; ++b) {
        const int i = env * n_agent_ + a, j = env * n_agent_ + b;
        if (team_of(a, ts) != team_of(b, ts) || !alive_[i] || !alive_[j]) continue;
        if (mover >= 0 && i != mover && j != mover) continue;
        const double dist = norm(goal_point_[i] - goal_point_[j]);
        if (dist >= sep) continue;
        double dr = goal_lateral_ft_[i] - goal_lateral_ft_[j], du = goal_vertical_ft_[i] - goal_vertical_ft_[j];
        if (dr * dr + du * du < 1e-6) {  // one point: part along the team slots' directions
          const double ta = 2.0 * kPi * (a % ts) / ts, tb = 2.0 * kPi * (b % ts) / ts;
          dr = std::cos(ta) - std::cos(tb), du = std::sin(ta) - std::sin(tb);
        }
        const double n = std::sqrt(dr * dr + du * du), push = (sep - dist) / n;
        const double wi = mover < 0 ? 0.5 : (i == mover ? 1.0 : 0.0);
        if (wi > 0.0) shift_goal(i, wi * push * dr, wi * push * du);
        if (wi < 1.0) shift_goal(j, -(1.0 - wi) * push * dr, -(1.0 - wi) * push * du);
        moved = true;
      }
    if (!moved) break;
  }
}

}  // namespace f16race::race
