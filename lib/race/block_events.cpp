#include "race/block_events.hpp"

#include <cmath>

namespace f16race::race {

BlockStepView block_view(const RaceEnv& env) {
  BlockStepView v;
  v.n_env = env.n_env();
  v.n_agent = env.n_agent();
  v.team_size = env.config().team_size;
  v.progress_ft = env.progress_ft_data();
  v.lateral_ft = env.lateral_ft_data();
  v.vertical_ft = env.vertical_ft_data();
  v.alive = env.alive_data();
  v.step_cause = env.step_cause();
  v.env_done = env.env_done();
  v.race_time_s = env.race_time_s_data();
  return v;
}

BlockCounter::BlockCounter(int n_env, int n_agent, int team_size, double dt_ll_s)
    : n_env_(n_env),
      n_agent_(n_agent),
      ts_(team_size),
      dt_s_(dt_ll_s),
      open_at_s_(static_cast<std::size_t>(n_env) * n_agent * n_agent, -1.0),
      ahead_at_open_(open_at_s_.size(), 0),
      blocks_(2 * static_cast<std::size_t>(n_env), 0),
      ended_(n_env, 0),
      last_t_s_(n_env, 0.0) {}

BlockCounter::BlockCounter(const RaceEnv& env)
    : BlockCounter(env.n_env(), env.n_agent(), env.config().team_size, env.config().dt_ll_s) {}

namespace {

// Live aircraft of b's team ahead of o along the track.
int team_ahead(const BlockStepView& v, int base, int b, int o) {
  const bool blue = b < v.team_size;
  int n = 0;
  for (int a = blue ? 0 : v.team_size; a < (blue ? v.team_size : v.n_agent); ++a)
    n += v.alive[base + a] && v.progress_ft[base + a] > v.progress_ft[base + o];
  return n;
}

}  // namespace

void BlockCounter::after_step(const BlockStepView& v) {
  for (int e = 0; e < n_env_; ++e) {
    if (ended_[e]) {  // the previous step ended the race: this is a new one
      blocks_[2 * e] = blocks_[2 * e + 1] = 0;
      ended_[e] = 0;
    }
    const int base = e * n_agent_;
    const bool done = v.env_done[e] != 0;
    // After a race's last step the env already holds the next race: only this step's causes
    // (not positions or ranks) belong to the race that ended.
    const double t = done ? last_t_s_[e] + dt_s_ : v.race_time_s[e];
    for (int b = 0; b < n_agent_; ++b) {
      for (int o = 0; o < n_agent_; ++o) {
        if ((b < ts_) == (o < ts_)) continue;  // opponents only
        const std::size_t k = (static_cast<std::size_t>(e) * n_agent_ + b) * n_agent_ + o;
        double& open = open_at_s_[k];
        // The window holds the steps up to kBlockWindowS after it opened (1e-9: float sums of dt);
        // an outcome after that is not this window's.
        if (open >= 0.0 && t - open > kBlockWindowS + 1e-9) open = -1.0;
        if (open >= 0.0) {
          const bool out = v.step_cause[base + o] != kCauseNone;
          const bool lost_rank = !done && !out && v.progress_ft[base + b] > v.progress_ft[base + o] &&
                                 team_ahead(v, base, b, o) > ahead_at_open_[k];
          if (out || lost_rank) {
            blocks_[2 * e + (b < ts_ ? 0 : 1)] += 1;
            events_.push_back({e, b, o, open, t, out});
            open = -1.0;
            continue;  // the pair's next window opens from the next step on
          }
          if (done) open = -1.0;
          if (open >= 0.0) continue;  // still running
        }
        if (done || !v.alive[base + b] || !v.alive[base + o]) continue;
        const double lead = v.progress_ft[base + b] - v.progress_ft[base + o];
        if (!(lead > 0.0 && lead <= kBlockAheadFt)) continue;
        if (std::hypot(v.lateral_ft[base + b] - v.lateral_ft[base + o],
                       v.vertical_ft[base + b] - v.vertical_ft[base + o]) > kBlockRadiusFt)
          continue;
        open = t;
        ahead_at_open_[k] = team_ahead(v, base, b, o);
      }
    }
    if (done) {
      ended_[e] = 1;
      last_t_s_[e] = 0.0;
    } else {
      last_t_s_[e] = t;
    }
  }
}

}  // namespace f16race::race
