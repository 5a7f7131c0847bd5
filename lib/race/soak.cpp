#include "race/soak.hpp"

#include <chrono>
#include <cmath>
#include <limits>
#include <vector>

#include "random/random_stream.hpp"

namespace f16race::race {

namespace {

enum Mode { kUniform, kNan, kInf, kHuge, kFlip, kMix, kNumModes };

float hostile_value(Mode mode, int step, RandomStream& rng) {
  const float inf = std::numeric_limits<float>::infinity();
  switch (mode) {
    case kUniform: return static_cast<float>(rng.uniform(-1.0, 1.0));
    case kNan: return std::numeric_limits<float>::quiet_NaN();
    case kInf: return rng.uniform() < 0.5 ? inf : -inf;
    case kHuge: return rng.uniform() < 0.5 ? 1e30f : -1e30f;
    case kFlip: return step % 2 == 0 ? 1.0f : -1.0f;
    default: return hostile_value(static_cast<Mode>(rng.below(kMix)), step, rng);
  }
}

std::int64_t count_non_finite(const float* p, std::int64_t n) {
  std::int64_t bad = 0;
  for (std::int64_t k = 0; k < n; ++k) bad += !std::isfinite(p[k]);
  return bad;
}

}  // namespace

SoakResult run_soak(const SoakOptions& o) {
  RaceEnv env(o.race);
  const int n = env.n_aircraft(), n_agent = env.n_agent();
  const std::int64_t n_other = static_cast<std::int64_t>(n) * (n_agent - 1);
  std::vector<float> actions(static_cast<std::size_t>(n) * kActionDim);
  std::vector<std::int64_t> bins(static_cast<std::size_t>(n) * kHlDims);
  std::vector<int> mode(n);
  RandomStream rng(o.seed, 0x50A4);
  auto draw_mode = [&](int i) { mode[i] = rng.below(kNumModes); };
  for (int i = 0; i < n; ++i) draw_mode(i);
  SoakResult r;
  const auto t0 = std::chrono::steady_clock::now();
  for (int step = 0; r.aircraft_steps < o.aircraft_steps; ++step) {
    // Bins far outside [0, hl_bins) too: the env clamps them.
    for (auto& b : bins) b = static_cast<std::int64_t>(rng.below(3 * o.race.hl_bins)) - o.race.hl_bins;
    for (int i = 0; i < n; ++i)
      for (int k = 0; k < kActionDim; ++k) {
        const float v = hostile_value(static_cast<Mode>(mode[i]), step, rng);
        r.hostile_actions += !std::isfinite(v) || std::fabs(v) > 1e3f;
        actions[static_cast<std::size_t>(i) * kActionDim + k] = v;
      }
    env.set_hl_actions(bins.data());
    const StepStats st = env.step(actions.data());
    r.aircraft_steps += n;
    r.races_finished += st.races_finished;
    for (int c = 0; c < kNumCauses; ++c) r.out[c] += st.terminations[c];
    r.non_finite += count_non_finite(env.obs_ego(), static_cast<std::int64_t>(n) * kEgoDim) +
                    count_non_finite(env.obs_goal(), static_cast<std::int64_t>(n) * kGoalDim) +
                    count_non_finite(env.obs_prev_action(), static_cast<std::int64_t>(n) * kActionDim) +
                    count_non_finite(env.obs_ado(), n_other * env.ado_dim()) +
                    count_non_finite(env.obs_task(), static_cast<std::int64_t>(n) * env.task_dim()) +
                    count_non_finite(env.ll_reward(), n) + count_non_finite(env.hl_reward(), n);
    // A new race gets new kinds of pilot.
    for (int e = 0; e < env.n_env(); ++e)
      if (env.env_done()[e])
        for (int a = 0; a < n_agent; ++a) draw_mode(e * n_agent + a);
  }
  r.seconds = std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
  return r;
}

}  // namespace f16race::race
