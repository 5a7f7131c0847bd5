// The per-step rewards of one env: the LL shaping terms of every aircraft that acted, and r_HL
// (race/ranking.hpp) of every aircraft of the race.
#include <algorithm>
#include <cmath>

#include "race/aircraft_state.hpp"
#include "race/race_env.hpp"
#include "race/ranking.hpp"

namespace f16race::race {

using namespace f16race::dynamics;

// progress_before_ft: [n_agent] the progress before the step, which the advance terms pay for.
// The HL team term goes to every aircraft of the race, also after it was taken out: being
// eliminated must never raise a team's return.
void RaceEnv::pay_rewards(int env, const double* progress_before_ft) {
  const RaceConfig& c = config_;
  const int base = env * n_agent_;
  for (int a = 0; a < n_agent_; ++a) {
    const int i = base + a;
    if (!acted_[i]) {
      ll_reward_[i] = 0.0f;
      hl_reward_[i] = static_cast<float>(race::hl_team_term(team_rank_[i]));
      continue;
    }
    hl_reward_[i] = static_cast<float>(race::hl_reward(team_rank_[i], prev_ego_rank_[i], ego_rank_[i]));
    const Vec3 d = goal_point_[i] - aircraft_position(sim_, i);
    const double gd = norm(d);
    double r = ll_reward_[i];  // already holds the action-change penalty
    r += c.w_goal_progress * (goal_dist_ft_[i] - gd) / c.goal_scale_ft;
    // Paid per start-speed step of progress (capped at 2: a projection jump at a corner pays no more).
    const double steps = (progress_ft_[i] - progress_before_ft[a]) / (c.start_speed_ftps * c.dt_ll_s);
    const double advance = std::clamp(steps, 0.0, 2.0);
    r += advance * c.w_goal_proximity * std::exp(-gd / c.goal_scale_ft);
    r += advance * c.w_goal_lane * std::exp(-goal_lane_error_ft(i) / c.goal_lane_scale_ft);
    r -= separation_penalty(i);
    goal_dist_ft_[i] = gd;
    if (dist_ft_[i] > radius_ft_[i]) r -= c.w_tube * c.dt_ll_s * (dist_ft_[i] - radius_ft_[i]) / radius_ft_[i];
    const double p = sim_.state(kP)[i], q = sim_.state(kQ)[i], rr = sim_.state(kR)[i];
    r -= c.w_rates * (p * p + q * q + rr * rr);
    if (cause_[i] == kCauseCollision && terminated_[i]) r -= c.w_collision;
    else if (terminated_[i]) r -= c.w_termination;
    ll_reward_[i] = static_cast<float>(r);
    prev_ego_rank_[i] = ego_rank_[i];
  }
}

double RaceEnv::separation_penalty(int i) const {
  const RaceConfig& c = config_;
  if (c.separation_ft <= 0.0 || c.w_separation == 0.0) return 0.0;
  const int env = i / n_agent_, a = i % n_agent_, team = team_of(a, c.team_size);
  // The collision pass measured these distances too; recomputing team_size - 1 of them is
  // cheaper than keeping an [n_env, n_agent, n_agent] matrix alive between the two systems.
  double sum = 0.0;
  for (int b = 0; b < n_agent_; ++b) {
    const int j = env * n_agent_ + b;
    if (b == a || !alive_[j] || team_of(b, c.team_size) != team) continue;
    const Vec3 d = aircraft_position(sim_, i) - aircraft_position(sim_, j);
    const double closeness = 1.0 - norm(d) / c.separation_ft;
    if (closeness > 0.0) sum += closeness * closeness;
  }
  return c.w_separation * sum;
}

double RaceEnv::goal_lane_error_ft(int i) const {
  // sqrt, not hypot: offsets are a few thousand feet, and hypot's overflow care costs per step.
  double right_ft, up_ft;
  goal_lane_here(i, &right_ft, &up_ft);
  const double dl = lateral_ft_[i] - right_ft, dv = vertical_ft_[i] - up_ft;
  return std::sqrt(dl * dl + dv * dv);
}

}  // namespace f16race::race
