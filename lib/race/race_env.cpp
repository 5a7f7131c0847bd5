#include "race/race_env.hpp"

#include <omp.h>

#include <algorithm>
#include <cmath>
#include <string>

#include "dynamics/inner_loop.hpp"
#include "io/yaml_config.hpp"
#include "race/aircraft_state.hpp"
#include "race/collisions.hpp"
#include "race/ranking.hpp"
#include "race/terminations.hpp"

namespace f16race::race {

using namespace f16race::dynamics;

namespace {

// The most throttle the Mach governor lets through: all of it below mach_max - 0.01 - band
// (kGovernorBandMach), none from mach_max - 0.01 on, linear between; the engine's lag and a dive
// make up the last 0.01. Proportional, so where thrust meets drag an aircraft settles at
// mach_max - 0.01 - band x throttle.
double governor_throttle_limit(double mach, double mach_max) {
  return std::clamp((mach_max - 0.01 - mach) / kGovernorBandMach, 0.0, 1.0);
}

// Element counts of the observation buffers, and the bytes of all of them plus their final
// copies (each padded for alignment): the size of the env's huge-page observation block.
struct ObservationSizes {
  std::size_t ego, action, goal, ado_rows, ado, task;
  explicit ObservationSizes(const RaceConfig& c) {
    const std::size_t n = static_cast<std::size_t>(c.n_env) * c.n_agent();
    ego = n * kEgoDim;
    action = n * kActionDim;
    goal = n * kGoalDim;
    ado_rows = n * (c.n_agent() - 1);
    ado = ado_rows * ado_dim(c);
    task = n * task_dim(c);
  }
  std::size_t bytes() const { return 2 * ((ego + action + goal + ado + task) * sizeof(float) + ado_rows + 6 * 64); }
};

F16BatchConfig batch_config(const RaceConfig& c) {
  F16BatchConfig b;
  b.n_env = c.n_env;
  b.n_agent = c.n_agent();
  b.model = c.model;
  b.integrator = Integrator::kRk4;
  return b;
}

}  // namespace

int task_dim(const RaceConfig& c) { return task_width(c.preview_points); }
int ado_dim(const RaceConfig&) { return kAdoDim; }

std::size_t RaceEnv::extent_size(Extent x) const {
  const ObservationSizes o(config_);
  switch (x) {
    case Extent::env: return static_cast<std::size_t>(n_env());
    case Extent::aircraft: return static_cast<std::size_t>(n_aircraft());
    case Extent::aircraft_hl: return static_cast<std::size_t>(n_aircraft()) * kHlDims;
    case Extent::obs_ego: return o.ego;
    case Extent::obs_action: return o.action;
    case Extent::obs_goal: return o.goal;
    case Extent::obs_ado: return o.ado;
    case Extent::obs_ado_rows: return o.ado_rows;
    case Extent::obs_task: return o.task;
  }
  return 0;
}

RaceEnv::RaceEnv(const RaceConfig& config, int first_env_id)
    : config_(config),
      n_agent_(config.n_agent()),
      task_dim_(race::task_dim(config)),
      ado_dim_(race::ado_dim(config)),
      sim_(batch_config(config)),
      obs_memory_(std::make_unique<HugePageMemory>(ObservationSizes(config).bytes())),
      obs_slice_(std::make_unique<std::pmr::monotonic_buffer_resource>(obs_memory_->data(), obs_memory_->size(),
                                                                       std::pmr::new_delete_resource())),
      ego_(obs_slice_.get()),
      prev_action_(obs_slice_.get()),
      goal_obs_(obs_slice_.get()),
      ado_(obs_slice_.get()),
      task_(obs_slice_.get()),
      ado_alive_(obs_slice_.get()),
      final_ego_(obs_slice_.get()),
      final_goal_(obs_slice_.get()),
      final_prev_action_(obs_slice_.get()),
      final_ado_(obs_slice_.get()),
      final_task_(obs_slice_.get()),
      final_ado_alive_(obs_slice_.get()) {
  validate_race_config(config_, "race config");
  // Level trims on a fine altitude grid covering every possible start height; a start altitude
  // snaps to the grid so each aircraft begins in exact trim.
  const double lo = config_.track.alt_min_ft - config_.track.radius_max_ft - trim_step_ft_;
  const double hi = config_.track.alt_max_ft + config_.track.radius_max_ft + trim_step_ft_;
  trim_alt0_ft_ = std::floor(lo / trim_step_ft_) * trim_step_ft_;
  const int n_trims = static_cast<int>(std::ceil((hi - trim_alt0_ft_) / trim_step_ft_)) + 1;
  trims_.reserve(n_trims);
  for (int k = 0; k < n_trims; ++k) {
    TrimRequest req;
    req.model = config_.model;
    req.vt_ftps = config_.start_speed_ftps;
    req.alt_ft = trim_alt0_ft_ + k * trim_step_ft_;
    try {
      trims_.push_back(trim_level_flight(req));
    } catch (const TrimError& e) {
      throw io::ConfigError(std::string("race.start_speed_ftps: ") + e.what());
    }
  }

  const std::size_t slice_bytes = (Track::storage_bytes(config_.track) + 4095) / 4096 * 4096;
  track_memory_ = std::make_unique<HugePageMemory>(slice_bytes * n_env());
  track_slices_.reserve(n_env());
  tracks_.reserve(n_env());
  for (int e = 0; e < n_env(); ++e) {
    track_slices_.push_back(std::make_unique<std::pmr::monotonic_buffer_resource>(
        track_memory_->data() + slice_bytes * e, slice_bytes, std::pmr::new_delete_resource()));
    tracks_.emplace_back(track_slices_.back().get(), config_.track);
  }
  if (config_.goal_line_frac > 0.0) lines_.resize(n_env());
  rng_.reserve(n_env());
  first_env_id_ = first_env_id;
  for (int e = 0; e < n_env(); ++e) rng_.emplace_back(config_.seed, static_cast<std::uint64_t>(first_env_id + e));
  visit_arrays(*this, [&](const char*, auto& v, Extent x, auto init) {
    v.assign(extent_size(x), static_cast<typename std::decay_t<decltype(v)>::value_type>(init));
  });
  step_stats_.assign(n_env(), StepStats{});
  final_ego_ = ego_;  // copies into the huge-page block: pmr assignment keeps the target's memory
  final_goal_ = goal_obs_;
  final_prev_action_ = prev_action_;
  final_ado_ = ado_;
  final_ado_alive_ = ado_alive_;
  final_task_ = task_;
  reset();
}

void RaceEnv::refresh() {
  sim_.evaluate_outputs();  // velocities and Nz in the observations come from the outputs
  for (int e = 0; e < n_env(); ++e) {
    update_track_geometry(e);
    compute_ranks(e);
    write_observations(e);
  }
}

void RaceEnv::update_track_geometry(int env) {
  const Track& tr = tracks_[env];
  for (int a = 0; a < n_agent_; ++a) {
    const int i = env * n_agent_ + a;
    if (!alive_[i] && track_hint_[i] >= 0) continue;  // frozen at its last position
    const TrackQuery q = tr.project(aircraft_position(sim_, i), track_hint_[i]);
    track_hint_[i] = q.index;
    progress_ft_[i] = q.s_ft;
    lateral_ft_[i] = q.lateral_ft;
    vertical_ft_[i] = q.vertical_ft;
    dist_ft_[i] = q.dist_ft;
    radius_ft_[i] = q.radius_ft;
  }
}

void RaceEnv::compute_ranks(int env) {
  const int base = env * n_agent_;
  race::compute_ranks(n_agent_, config_.team_size, &alive_[base], &progress_ft_[base], &ego_rank_[base],
                      &team_rank_[base]);
}

StepStats RaceEnv::step(const float* actions) {
  const RaceConfig& c = config_;
  const int n_envs = n_env();
#pragma omp parallel for schedule(static)
  for (int e = 0; e < n_envs; ++e) apply_actions(e * n_agent_, (e + 1) * n_agent_, actions);
  sim_.step(c.dt_ll_s / c.substeps, c.substeps);
  sim_.evaluate_outputs();
  // Contiguous env ranges per thread, as schedule(static) makes them, like the simulator's own
  // loop: each thread reads the states its core just wrote (measured: dynamic scheduling costs
  // 4 points of overhead at 2 threads). The explicit range lets a thread prefetch its next env
  // without touching one that another thread is updating.
#pragma omp parallel
  {
    const int nt = omp_get_num_threads(), chunk = (n_envs + nt - 1) / nt;
    const int e0 = std::min(omp_get_thread_num() * chunk, n_envs), e1 = std::min(e0 + chunk, n_envs);
    for (int e = e0; e < e1; ++e) {
      if (e + 1 < e1) prefetch_track(e + 1);
      step_env(e);
    }
  }
  StepStats total;
  for (const StepStats& s : step_stats_) {
    for (int k = 0; k < kNumCauses; ++k) total.terminations[k] += s.terminations[k];
    total.races_finished += s.races_finished;
    total.races_won[0] += s.races_won[0];
    total.races_won[1] += s.races_won[1];
    total.races_drawn += s.races_drawn;
    total.races_by_finish_line += s.races_by_finish_line;
    total.races_by_elimination += s.races_by_elimination;
    total.races_by_time_limit += s.races_by_time_limit;
    total.aircraft_alive_at_end += s.aircraft_alive_at_end;
  }
  return total;
}

// The env's track lines that its step will read (segment frames at its hints, the preview table
// ahead of its pack) are cold when its turn comes: the simulator step streamed everything else
// through the cache. Asked for one env ahead, their latency overlaps the current env's work
// (measured: 5 points of overhead at 1 thread).
void RaceEnv::prefetch_track(int env) const {
  const int base = env * n_agent_;
  tracks_[env].prefetch(n_agent_, &track_hint_[base], &progress_ft_[base],
                        config_.preview_points * config_.preview_spacing_ft);
}

// Actions -> references for aircraft [i0, i1) still racing.
void RaceEnv::apply_actions(int i0, int i1, const float* actions) {
  const RaceConfig& c = config_;
  for (int i = i0; i < i1; ++i) {
    acted_[i] = alive_[i];
    step_cause_[i] = kCauseNone;
    terminated_[i] = 0;
    truncated_[i] = 0;
    if (!alive_[i]) continue;
    const float* a = actions + static_cast<std::size_t>(i) * kActionDim;
    float* la = &prev_action_[static_cast<std::size_t>(i) * kActionDim];  // read, then overwritten
    double da2 = 0.0;
    for (int k = 0; k < kActionDim; ++k) {
      // NaN from a broken policy counts as 0 (neutral) rather than reaching the flight model.
      const float v = std::isnan(a[k]) ? 0.0f : std::min(std::max(a[k], -1.0f), 1.0f);
      da2 += (v - la[k]) * (v - la[k]);
      la[k] = v;
    }
    ll_reward_[i] = static_cast<float>(-c.w_action_change * da2);
    double throttle = 0.5 * (la[0] + 1.0);
    // Mach of the state the step starts from (the envelope check reads the state it ends in).
    if (c.mach_governor)
      throttle = std::min(throttle, governor_throttle_limit(aircraft_mach(sim_, i), c.mach_max));
    sim_.ref(kThrottleDelta)[i] = throttle - lqr::kThrottleEquil;
    sim_.ref(kNzRef)[i] = c.nz_ref_min_g + 0.5 * (la[1] + 1.0) * (c.nz_ref_max_g - c.nz_ref_min_g);
    sim_.ref(kPsRef)[i] = la[2] * c.ps_ref_max_radps;
    sim_.ref(kNyRRef)[i] = 0.0;
  }
}

// One env's race after the flight step, a system each: track geometry, terminations and
// collisions, ranks, goals, rewards, the race's end (and next start), observations.
void RaceEnv::step_env(int e) {
  const RaceConfig& c = config_;
  step_stats_[e] = StepStats{};
  const int base = e * n_agent_;
  time_s_[e] += c.dt_ll_s;
  double progress_before_ft[16];  // [n_agent]: the progress rewards pay for the step's advance
  for (int a = 0; a < n_agent_; ++a) progress_before_ft[a] = progress_ft_[base + a];
  update_track_geometry(e);
  std::int8_t new_cause[16] = {};
  find_terminations(c, sim_, base, n_agent_, &alive_[base], &dist_ft_[base], &radius_ft_[base], &tube_out_s_[base],
                    new_cause);
  find_collisions(c, sim_, base, n_agent_, &acted_[base], new_cause);
  take_out(e, new_cause);
  compute_ranks(e);
  refresh_reached_goals(e);
  pay_rewards(e, progress_before_ft);
  if (!end_race_if_over(e)) {
    hl_time_left_s_[e] -= c.dt_ll_s;
    if (hl_time_left_s_[e] <= 1e-9) hl_due_[e] = 1;
  }
  write_observations(e);
}

}  // namespace f16race::race
