#include "race/race_env.hpp"

#include <omp.h>

#include <algorithm>
#include <cmath>
#include <istream>
#include <ostream>
#include <stdexcept>
#include <string>

#include "dynamics/engine.hpp"
#include "dynamics/inner_loop.hpp"
#include "dynamics/physical_constants.hpp"
#include "dynamics/vector_math.hpp"
#include "io/yaml_config.hpp"
#include "race/ranking.hpp"

namespace f16race::race {

using namespace f16race::dynamics;

namespace {


float clampf(double v, double lo, double hi) { return static_cast<float>(std::min(std::max(v, lo), hi)); }

Vec3 position(const F16Batch& sim, int i) { return {sim.state(kPn)[i], sim.state(kPe)[i], sim.state(kAlt)[i]}; }

double mach_of(const F16Batch& sim, int i) { return air_data(sim.state(kVt)[i], sim.state(kAlt)[i]).mach; }

// The most throttle the Mach governor lets through: all of it below mach_max - 0.05, none from
// mach_max - 0.01 on, linear between; the engine's lag and a dive make up the last 0.01.
double governor_throttle_limit(double mach, double mach_max) {
  return std::clamp((mach_max - 0.01 - mach) / 0.04, 0.0, 1.0);
}

// Heading-aligned ego frame: x forward along psi, y to the right, z up.
struct EgoFrame {
  double c, s;
  void apply(const Vec3& d, double* x, double* y, double* z) const {
    *x = c * d.n + s * d.e;
    *y = -s * d.n + c * d.e;
    *z = d.u;
  }
};

}  // namespace

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

int task_dim(const RaceConfig& c) { return task_width(c.preview_points); }
int ado_dim(const RaceConfig&) { return kAdoDim; }

namespace {
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

void RaceEnv::copy_final_observations(int env) {
  const std::size_t a0 = static_cast<std::size_t>(env) * n_agent_, a1 = a0 + n_agent_;
  auto copy = [&](const auto& src, auto& dst, std::size_t width) {
    std::copy(src.begin() + a0 * width, src.begin() + a1 * width, dst.begin() + a0 * width);
  };
  copy(ego_, final_ego_, kEgoDim);
  copy(goal_obs_, final_goal_, kGoalDim);
  copy(prev_action_, final_prev_action_, kActionDim);
  copy(ado_, final_ado_, static_cast<std::size_t>(n_agent_ - 1) * ado_dim_);
  copy(ado_alive_, final_ado_alive_, static_cast<std::size_t>(n_agent_ - 1));
  copy(task_, final_task_, static_cast<std::size_t>(task_dim_));
}

void RaceEnv::refresh() {
  sim_.evaluate_outputs();  // velocities and Nz in the observations come from the outputs
  for (int e = 0; e < n_env(); ++e) {
    update_track_geometry(e);
    compute_ranks(e);
    write_observations(e);
  }
}

void RaceEnv::reset_env(int env) {
  RandomStream& rng = rng_[env];
  tracks_[env] = Track::generate(config_.track, rng);
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

void RaceEnv::update_track_geometry(int env) {
  const Track& tr = tracks_[env];
  for (int a = 0; a < n_agent_; ++a) {
    const int i = env * n_agent_ + a;
    if (!alive_[i] && track_hint_[i] >= 0) continue;  // frozen at its last position
    const TrackQuery q = tr.project(position(sim_, i), track_hint_[i]);
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
  const Vec3 along = dot(off, fr.tangent) * fr.tangent;
  const Vec3 cross = off - along;
  const double c = std::sqrt(dot(cross, cross)), limit = config_.goal_bin_scale * fr.radius_ft;
  if (c > limit) off = along + (limit / c) * cross;
  goal_point_[i] = fr.center + off;
  goal_lateral_ft_[i] = dot(off, fr.right);
  goal_vertical_ft_[i] = dot(off, fr.up);
  const Vec3 d = goal_point_[i] - position(sim_, i);
  goal_dist_ft_[i] = std::sqrt(dot(d, d));
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
    if (c.mach_governor) throttle = std::min(throttle, governor_throttle_limit(mach_of(sim_, i), c.mach_max));
    sim_.ref(kThrottleDelta)[i] = throttle - lqr::kThrottleEquil;
    sim_.ref(kNzRef)[i] = c.nz_ref_min_g + 0.5 * (la[1] + 1.0) * (c.nz_ref_max_g - c.nz_ref_min_g);
    sim_.ref(kPsRef)[i] = la[2] * c.ps_ref_max_radps;
    sim_.ref(kNyRRef)[i] = 0.0;
  }
}

void RaceEnv::step_env(int e) {
  const RaceConfig& c = config_;
  step_stats_[e] = StepStats{};
  StepStats& st = step_stats_[e];
  const int base = e * n_agent_;
  time_s_[e] += c.dt_ll_s;
  double progress_before_ft[16];  // [n_agent]: the progress rewards pay for the step's advance
  for (int a = 0; a < n_agent_; ++a) progress_before_ft[a] = progress_ft_[base + a];
  update_track_geometry(e);
  std::int8_t new_cause[16] = {};
  double sphi[16], cphi[16], sth[16], cth[16];
  {
    const double* phi = sim_.state(kPhi) + base;
    const double* theta = sim_.state(kTheta) + base;
#pragma omp simd
    for (int a = 0; a < n_agent_; ++a) {
      vmath::sincos(phi[a], &sphi[a], &cphi[a]);
      vmath::sincos(theta[a], &sth[a], &cth[a]);
    }
  }
  for (int a = 0; a < n_agent_; ++a) {
    const int i = base + a;
    if (!alive_[i]) continue;
    const double psi_dot = (sim_.state(kQ)[i] * sphi[a] + sim_.state(kR)[i] * cphi[a]) / cth[a];
    const double nz = sim_.output(kOutNz)[i];
    const double alt = sim_.state(kAlt)[i];
    const bool outside = dist_ft_[i] > radius_ft_[i];
    tube_out_s_[i] = outside ? tube_out_s_[i] + c.dt_ll_s : 0.0;
    std::int8_t cause = kCauseNone;
    if (sim_.status()[i] != kStatusOk) cause = kCauseSimulator;
    else if (alt < c.alt_min_ft || alt > c.alt_max_ft) cause = kCauseAltitude;
    else if (nz < c.nz_min_g || nz > c.nz_max_g) cause = kCauseLoad;
    else if (std::fabs(psi_dot) * 180.0 / kPi > c.turn_rate_max_dps) cause = kCauseTurnRate;
    else if (outside && (c.tube_exit == TubeExit::kTerminate || tube_out_s_[i] > c.tube_grace_s)) cause = kCauseTube;
    else if (c.mach_max > 0.0 && mach_of(sim_, i) > c.mach_max) cause = kCauseEnvelope;
    new_cause[a] = cause;
  }
  // Collisions between any two aircraft that flew this step: both are out.
  for (int a = 0; a < n_agent_; ++a) {
    const int i = base + a;
    if (!acted_[i]) continue;
    for (int b = a + 1; b < n_agent_; ++b) {
      const int j = base + b;
      if (!acted_[j]) continue;
      const Vec3 d = position(sim_, i) - position(sim_, j);
      if (dot(d, d) < c.collision_radius_ft * c.collision_radius_ft) {
        // A teammate's collision outranks an opponent's in the same step.
        const std::int8_t hit = team_of(a, c.team_size) == team_of(b, c.team_size) ? kCauseTeamCollision : kCauseCollision;
        for (const int k : {a, b})
          if (new_cause[k] == kCauseNone || (new_cause[k] == kCauseCollision && hit == kCauseTeamCollision))
            new_cause[k] = hit;
      }
    }
  }
  for (int a = 0; a < n_agent_; ++a) {
    const int i = base + a;
    if (new_cause[a] == kCauseNone) continue;
    alive_[i] = 0;
    cause_[i] = new_cause[a];
    step_cause_[i] = new_cause[a];
    terminated_[i] = 1;
    st.terminations[new_cause[a]] += 1;
    sim_.status()[i] = kStatusRetired;  // frozen where it was taken out
  }
  compute_ranks(e);

  // A goal the aircraft has (nearly) reached is placed again at the horizon with the same bins:
  // the decision holds for the whole HL interval, whatever its length. The placement resets the
  // distance the progress reward is measured from, so the jump itself pays nothing.
  if (c.goal_refresh_ft > 0.0) {
    for (int a = 0; a < n_agent_; ++a) {
      const int i = base + a;
      if (alive_[i] && progress_ft_[i] + c.goal_refresh_ft >= goal_progress_ft_[i]) {
        place_goal(i, &goal_bins_[static_cast<std::size_t>(i) * kHlDims]);
        separate_goals(e, i);  // the teammates keep their goals: only the new one moves
      }
    }
  }

  // Rewards for every aircraft that acted this step. The HL team term goes to every aircraft of
  // the race, also after it was taken out: being eliminated must never raise a team's return.
  for (int a = 0; a < n_agent_; ++a) {
    const int i = base + a;
    if (!acted_[i]) {
      ll_reward_[i] = 0.0f;
      hl_reward_[i] = static_cast<float>(race::hl_team_term(team_rank_[i]));
      continue;
    }
    hl_reward_[i] = static_cast<float>(race::hl_reward(team_rank_[i], prev_ego_rank_[i], ego_rank_[i]));
    const Vec3 d = goal_point_[i] - position(sim_, i);
    const double gd = std::sqrt(dot(d, d));
    double r = ll_reward_[i];  // already holds the action-change penalty
    r += c.w_goal_progress * (goal_dist_ft_[i] - gd) / c.goal_scale_ft;
    // Paid per start-speed step of progress (capped at 2: a projection jump at a corner pays no more).
    const double advance = std::clamp((progress_ft_[i] - progress_before_ft[a]) / (c.start_speed_ftps * c.dt_ll_s), 0.0, 2.0);
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

  // Race end: finish line, a whole team out, or the time limit.
  bool finished = false;
  int team_alive[2] = {0, 0};
  for (int a = 0; a < n_agent_; ++a) {
    const int i = base + a;
    team_alive[team_of(a, c.team_size)] += alive_[i];
    finished = finished || (alive_[i] && progress_ft_[i] >= tracks_[e].length_ft() - c.finish_margin_ft);
  }
  const bool eliminated = team_alive[0] == 0 || team_alive[1] == 0;
  const bool timeout = time_s_[e] >= c.time_limit_s - 1e-9;
  env_done_[e] = finished || eliminated || timeout;
  if (env_done_[e]) {
    st.races_finished = 1;
    const double tr_blue = team_rank_[base];
    if (tr_blue == 0.0) st.races_won[0] = 1;
    else if (tr_blue == 1.0) st.races_won[1] = 1;
    else st.races_drawn = 1;
    st.races_by_finish_line = finished;
    st.races_by_elimination = !finished && eliminated;
    st.races_by_time_limit = !finished && !eliminated;
    race_winner_[e] = static_cast<std::int8_t>(tr_blue == 0.0 ? 0 : (tr_blue == 1.0 ? 1 : -1));
    race_end_[e] = finished ? kEndFinishLine : (eliminated ? kEndElimination : kEndTimeLimit);
    for (int a = 0; a < n_agent_; ++a) {
      const int i = base + a;
      if (!alive_[i]) continue;
      st.aircraft_alive_at_end += 1;
      if (finished || eliminated || c.time_limit_terminal) terminated_[i] = 1;
      else truncated_[i] = 1;
    }
    if (st.races_by_time_limit && !c.time_limit_terminal) {
      write_observations(e);
      copy_final_observations(e);
    }
    reset_env(e);
  } else {
    hl_time_left_s_[e] -= c.dt_ll_s;
    if (hl_time_left_s_[e] <= 1e-9) hl_due_[e] = 1;
  }
  write_observations(e);
}

void RaceEnv::shift_goal(int i, double right_ft, double up_ft) {
  const TrackFrame fr = tracks_[i / n_agent_].frame_at(goal_progress_ft_[i]);
  Vec3 off = goal_point_[i] - fr.center + right_ft * fr.right + up_ft * fr.up;
  const Vec3 along = dot(off, fr.tangent) * fr.tangent, cross = off - along;
  const double c = std::sqrt(dot(cross, cross)), limit = config_.goal_bin_scale * fr.radius_ft;
  if (c > limit) off = along + (limit / c) * cross;  // at the outer bins' radius the best it can do
  goal_point_[i] = fr.center + off;
  goal_lateral_ft_[i] = dot(off, fr.right);
  goal_vertical_ft_[i] = dot(off, fr.up);
  const Vec3 d = goal_point_[i] - position(sim_, i);
  goal_dist_ft_[i] = std::sqrt(dot(d, d));  // the progress reward counts from the moved goal
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
        const Vec3 d = goal_point_[i] - goal_point_[j];
        const double dist = std::sqrt(dot(d, d));
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

double RaceEnv::separation_penalty(int i) const {
  const RaceConfig& c = config_;
  if (c.separation_ft <= 0.0 || c.w_separation == 0.0) return 0.0;
  const int env = i / n_agent_, a = i % n_agent_, team = team_of(a, c.team_size);
  double sum = 0.0;
  for (int b = 0; b < n_agent_; ++b) {
    const int j = env * n_agent_ + b;
    if (b == a || !alive_[j] || team_of(b, c.team_size) != team) continue;
    const Vec3 d = position(sim_, i) - position(sim_, j);
    const double closeness = 1.0 - std::sqrt(dot(d, d)) / c.separation_ft;
    if (closeness > 0.0) sum += closeness * closeness;
  }
  return c.w_separation * sum;
}

double RaceEnv::goal_lane_error_ft(int i) const {
  // sqrt, not hypot: offsets are a few thousand feet, and hypot's overflow care costs per step.
  const double dl = lateral_ft_[i] - goal_lateral_ft_[i], dv = vertical_ft_[i] - goal_vertical_ft_[i];
  return std::sqrt(dl * dl + dv * dv);
}

// The HL goal as the LL policy sees it: how far ahead along the track (/ goal_ahead, in [0, 10])
// and how far across it, right and up in the tube's cross-section (/ the local radius, +-10): the
// lane the high level chose, relative to the aircraft's own.
void RaceEnv::write_goal_observation(int i) {
  const double ahead = std::min(goal_progress_ft_[i], tracks_[i / n_agent_].length_ft()) - progress_ft_[i];
  float* g = &goal_obs_[static_cast<std::size_t>(i) * kGoalDim];
  g[kGoalAhead] = static_cast<float>(std::clamp(ahead / config_.goal_ahead(), 0.0, 10.0));
  g[kGoalLaneRight] =
      static_cast<float>(std::clamp((goal_lateral_ft_[i] - lateral_ft_[i]) / radius_ft_[i], -10.0, 10.0));
  g[kGoalLaneUp] =
      static_cast<float>(std::clamp((goal_vertical_ft_[i] - vertical_ft_[i]) / radius_ft_[i], -10.0, 10.0));
}

void RaceEnv::write_observations(int env) {
  // Float arithmetic where the buffers are float (float sqrt/div are twice as fast), and every
  // per-aircraft, per-pair and per-preview-point computation is a straight loop over small local
  // arrays that GCC vectorises (`omp simd`); only gathers and the final scatter into the
  // interleaved buffers are scalar. Measured 2.5x faster than the row-by-row version.
  constexpr int kMaxAgents = 16;   // 8 vs 8
  constexpr int kMaxPreview = 64;  // race_config: preview_points <= 64
  const RaceConfig& c = config_;
  const int base = env * n_agent_;
  const Track& tr = tracks_[env];
  const int na = n_agent_;
  // Positions relative to the first aircraft keep float precision on long tracks.
  // Padded to kMaxAgents with zeros: the vector loops below run the full fixed length (one
  // 16-lane iteration), which is faster than a loop of na iterations and its remainder.
  float pn_rel_ft[kMaxAgents] = {}, pe_rel_ft[kMaxAgents] = {}, pu_rel_ft[kMaxAgents] = {};  // north/east/up
  float vn_ftps[kMaxAgents] = {}, ve_ftps[kMaxAgents] = {}, vu_ftps[kMaxAgents] = {};
  float prog[kMaxAgents] = {}, alive_f[kMaxAgents] = {};
  float ang[5][kMaxAgents] = {};
  for (int a = 0; a < na; ++a) {
    const int i = base + a;
    pn_rel_ft[a] = static_cast<float>(sim_.state(kPn)[i] - sim_.state(kPn)[base]);
    pe_rel_ft[a] = static_cast<float>(sim_.state(kPe)[i] - sim_.state(kPe)[base]);
    pu_rel_ft[a] = static_cast<float>(sim_.state(kAlt)[i] - sim_.state(kAlt)[base]);
    vn_ftps[a] = static_cast<float>(sim_.output(kOutVn)[i]);
    ve_ftps[a] = static_cast<float>(sim_.output(kOutVe)[i]);
    vu_ftps[a] = static_cast<float>(sim_.output(kOutVu)[i]);
    prog[a] = static_cast<float>((progress_ft_[i] - progress_ft_[base]) / 5000.0);
    alive_f[a] = alive_[i] ? 1.0f : 0.0f;
    ang[0][a] = static_cast<float>(sim_.state(kAlpha)[i]);
    ang[1][a] = static_cast<float>(sim_.state(kBeta)[i]);
    ang[2][a] = static_cast<float>(sim_.state(kPhi)[i]);
    ang[3][a] = static_cast<float>(sim_.state(kTheta)[i]);
    ang[4][a] = static_cast<float>(sim_.state(kPsi)[i]);
  }
  // Attitude trig of every aircraft of the env: [angle][agent], one 16-lane float pass per
  // angle (the observations are float; float sin/cos is exact to ~2e-7 here).
  // The bound is a runtime 16 on purpose: with a constant one GCC unrolls the loop fully and then
  // fails to if-convert it.
  float sn[5][kMaxAgents], cs[5][kMaxAgents];
  const int na_pad = (na + 15) / 16 * 16;
  for (int k = 0; k < 5; ++k) {
#pragma omp simd
    for (int a = 0; a < na_pad; ++a) vmath::sincosf(ang[k][a], &sn[k][a], &cs[k][a]);
  }
  const float* cos_psi = cs[4];
  const float* sin_psi = sn[4];
  for (int a = 0; a < na; ++a) {
    const int i = base + a;
    write_goal_observation(i);
    float* o = &ego_[static_cast<std::size_t>(i) * kEgoDim];
    o[kEgoVt] = static_cast<float>(sim_.state(kVt)[i] / 1000.0);
    for (int k = 0; k < 5; ++k) {
      o[kEgoAttitudeTrig + 2 * k] = sn[k][a];
      o[kEgoAttitudeTrig + 1 + 2 * k] = cs[k][a];
    }
    o[kEgoBodyRates] = clampf(sim_.state(kP)[i] / 2.0, -10.0, 10.0);
    o[kEgoBodyRates + 1] = clampf(sim_.state(kQ)[i], -10.0, 10.0);
    o[kEgoBodyRates + 2] = clampf(sim_.state(kR)[i], -10.0, 10.0);
    o[kEgoAltitude] = static_cast<float>(sim_.state(kAlt)[i] / 10000.0);
    o[kEgoPower] = static_cast<float>(sim_.state(kPow)[i] / 100.0);
    o[kEgoIntegrators] = clampf(sim_.state(kIntNz)[i] / 5.0, -10.0, 10.0);
    o[kEgoIntegrators + 1] = clampf(sim_.state(kIntPs)[i] / 2.0, -10.0, 10.0);
    o[kEgoIntegrators + 2] = clampf(sim_.state(kIntNyR)[i] / 2.0, -10.0, 10.0);
    o[kEgoNz] = clampf(sim_.output(kOutNz)[i] / 5.0, -10.0, 10.0);
  }
  const int my_team_end = c.team_size;
  for (int a = 0; a < na; ++a) {
    const int i = base + a;
    const float ca = cs[4][a], sa = sn[4][a];
    // Features of every aircraft b as seen from a ([feature][b]); a dead b gets zeros.
    float f[kAdoSameTeam][kMaxAgents];  // the geometric entries, before the team and alive flags
#pragma omp simd
    for (int b = 0; b < kMaxAgents; ++b) {
      // North/east/up differences, then the ego's heading frame (_hdg): x forward, y right.
      const float dn = pn_rel_ft[b] - pn_rel_ft[a], de = pe_rel_ft[b] - pe_rel_ft[a], du = pu_rel_ft[b] - pu_rel_ft[a];
      const float h2 = dn * dn + de * de, rh = std::sqrt(h2), r = std::sqrt(h2 + du * du);
      const float x_hdg = ca * dn + sa * de, y_hdg = -sa * dn + ca * de;
      const float inv_rh = rh > 1e-3f ? 1.0f / rh : 0.0f, inv_r = r > 1e-3f ? 1.0f / r : 0.0f;
      const float vn = vn_ftps[b] - vn_ftps[a], ve = ve_ftps[b] - ve_ftps[a];
      // Masked by a multiply (GCC does not vectorise the select here): a dead aircraft's frozen
      // state is its last finite one, so m = 0 gives exact zeros.
      const float m = alive_f[b];
      f[kAdoRange][b] = m * std::min(r * (1.0f / 5000.0f), 10.0f);
      f[kAdoAzimuth][b] = m * (inv_rh > 0.0f ? y_hdg * inv_rh : 0.0f);
      f[kAdoAzimuth + 1][b] = m * (inv_rh > 0.0f ? x_hdg * inv_rh : 1.0f);
      f[kAdoSinElevation][b] = m * (du * inv_r);
      f[kAdoRelVelocity][b] = m * ((ca * vn + sa * ve) * (1.0f / 500.0f));
      f[kAdoRelVelocity + 1][b] = m * ((-sa * vn + ca * ve) * (1.0f / 500.0f));
      f[kAdoRelVelocity + 2][b] = m * ((vu_ftps[b] - vu_ftps[a]) * (1.0f / 500.0f));
      f[kAdoProgress][b] = m * std::min(std::max(prog[b] - prog[a], -10.0f), 10.0f);
      // Closest approach if both hold their velocity (what TCAS computes): when, and how close.
      const float vu = vu_ftps[b] - vu_ftps[a];
      const float rv = dn * vn + de * ve + du * vu, v2 = vn * vn + ve * ve + vu * vu;
      const float t_cpa = v2 > 1e-6f ? std::max(-rv / v2, 0.0f) : 0.0f;
      const float mn = dn + vn * t_cpa, me = de + ve * t_cpa, mu = du + vu * t_cpa;
      f[kAdoClosing][b] = m * std::min(std::max(-rv * inv_r * (1.0f / 500.0f), -10.0f), 10.0f);
      f[kAdoTimeToClosest][b] = m * std::min(t_cpa * 0.1f, 1.0f);
      f[kAdoMissDistance][b] = m * std::min(std::sqrt(mn * mn + me * me + mu * mu) * (1.0f / 1000.0f), 10.0f);
    }
    // Other aircraft in agent order (self skipped), so permuting them permutes rows only.
    const bool a_blue = a < my_team_end;
    int row = 0;
    for (int b = 0; b < na; ++b) {
      if (b == a) continue;
      const std::size_t r = static_cast<std::size_t>(i) * (na - 1) + row++;
      float* d = &ado_[r * ado_dim_];
      for (int q = 0; q < kAdoSameTeam; ++q) d[q] = f[q][b];
      d[kAdoSameTeam] = (b < my_team_end) == a_blue ? 1.0f : 0.0f;
      d[kAdoAlive] = alive_f[b];
      ado_alive_[r] = alive_[base + b];
    }
  }
  // Track preview: every (aircraft, point) pair in two vector passes.
  const int np = c.preview_points;
  const int nk = na * np;
  float qn[kMaxAgents * kMaxPreview], qe[kMaxAgents * kMaxPreview], qu[kMaxAgents * kMaxPreview];
  float qr[kMaxAgents * kMaxPreview];
  tr.preview(na, np, c.preview_spacing_ft, &progress_ft_[base], sim_.state(kPn) + base, sim_.state(kPe) + base,
             sim_.state(kAlt) + base, qn, qe, qu, qr);
  const float inv_np = 1.0f / static_cast<float>(np);
  float g[4][kMaxAgents * kMaxPreview];
#pragma omp simd
  for (int k = 0; k < nk; ++k) {
    const int a = Track::preview_agent(k, inv_np);
    const float ca = cos_psi[a], sa = sin_psi[a];
    const float x = ca * qn[k] + sa * qe[k], y = -sa * qn[k] + ca * qe[k], du = qu[k];
    const float rh = std::sqrt(x * x + y * y), rr = std::sqrt(rh * rh + du * du);
    g[0][k] = std::min(rr * (1.0f / 5000.0f), 10.0f);
    g[1][k] = rh > 1e-3f ? y / rh : 0.0f;
    g[2][k] = rh > 1e-3f ? x / rh : 1.0f;
    g[3][k] = rr > 1e-3f ? du / rr : 0.0f;
  }
  for (int a = 0; a < na; ++a) {
    const int i = base + a;
    float* t = &task_[static_cast<std::size_t>(i) * task_dim_];
    for (int p = 0; p < np; ++p) {
      const int k = a * np + p;
      float* tp = t + kPreviewWidth * p;
      tp[kPreviewRange] = g[0][k];
      tp[kPreviewAzimuth] = g[1][k];
      tp[kPreviewAzimuth + 1] = g[2][k];
      tp[kPreviewSinElevation] = g[3][k];
      tp[kPreviewRadius] = qr[k] * (1.0f / 2000.0f);
    }
    float* u = t + kPreviewWidth * np;
    u[kTaskOffsets] = clampf(lateral_ft_[i] / radius_ft_[i], -10.0, 10.0);
    u[kTaskOffsets + 1] = clampf(vertical_ft_[i] / radius_ft_[i], -10.0, 10.0);
    u[kTaskCenterDistance] = clampf(dist_ft_[i] / radius_ft_[i], 0.0, 10.0);
    u[kTaskProgress] = static_cast<float>(progress_ft_[i] / tr.length_ft());
    u[kTaskTimeLeft] = static_cast<float>(1.0 - time_s_[env] / c.time_limit_s);
    u[kTaskHlTimeLeft] = static_cast<float>(std::max(hl_time_left_s_[env], 0.0) / c.dt_hl_s);
    u[kTaskEgoRank] = static_cast<float>(ego_rank_[i]) / static_cast<float>(na - 1);
    u[kTaskTeamRank] = static_cast<float>(team_rank_[i]);
  }
}

}  // namespace f16race::race

namespace f16race::race {
namespace {

template <typename Vector>
void put_vec(std::ostream& out, const Vector& v) {
  using T = typename Vector::value_type;
  const std::int64_t n = static_cast<std::int64_t>(v.size());
  out.write(reinterpret_cast<const char*>(&n), sizeof n);
  out.write(reinterpret_cast<const char*>(v.data()), static_cast<std::streamsize>(n * sizeof(T)));
}

template <typename Vector>
void get_vec(std::istream& in, Vector* v, const char* what) {
  using T = typename Vector::value_type;
  std::int64_t n = -1;
  in.read(reinterpret_cast<char*>(&n), sizeof n);
  if (!in || n != static_cast<std::int64_t>(v->size()))
    throw std::runtime_error(std::string("race snapshot: '") + what + "' has the wrong size (another config?)");
  in.read(reinterpret_cast<char*>(v->data()), static_cast<std::streamsize>(n * sizeof(T)));
  if (!in) throw std::runtime_error(std::string("race snapshot is truncated at '") + what + "'");
}

}  // namespace

void RaceEnv::save_state(std::ostream& out) const {
  sim_.save_state(out);
  std::vector<std::uint64_t> rng(n_env());
  for (int e = 0; e < n_env(); ++e) rng[e] = rng_[e].state();
  put_vec(out, rng);
  for (int e = 0; e < n_env(); ++e) {
    std::vector<double> w;
    for (const Waypoint& p : tracks_[e].waypoints()) w.insert(w.end(), {p.p.n, p.p.e, p.p.u, p.radius_ft});
    const std::int64_t n = static_cast<std::int64_t>(w.size());
    out.write(reinterpret_cast<const char*>(&n), sizeof n);
    out.write(reinterpret_cast<const char*>(w.data()), static_cast<std::streamsize>(n * sizeof(double)));
  }
  visit_arrays(*this, [&](const char*, const auto& v, Extent, auto) { put_vec(out, v); });
}

std::vector<RaceEnv::SnapshotArray> RaceEnv::snapshot_layout() const {
  std::vector<SnapshotArray> out;
  visit_arrays(*this, [&](const char* name, const auto& v, Extent, auto) {
    out.push_back({name, v.size(), v.size() * sizeof(typename std::decay_t<decltype(v)>::value_type)});
  });
  return out;
}

void RaceEnv::load_state(std::istream& in) {
  sim_.load_state(in);
  std::vector<std::uint64_t> rng(n_env());
  get_vec(in, &rng, "random streams");
  for (int e = 0; e < n_env(); ++e) rng_[e].set_state(rng[e]);
  for (int e = 0; e < n_env(); ++e) {
    std::int64_t n = -1;
    in.read(reinterpret_cast<char*>(&n), sizeof n);
    if (!in || n < 16 || n % 4 != 0 || n > 4 * 100000) throw std::runtime_error("race snapshot: bad track record");
    std::vector<double> w(static_cast<std::size_t>(n));
    in.read(reinterpret_cast<char*>(w.data()), static_cast<std::streamsize>(n * sizeof(double)));
    if (!in) throw std::runtime_error("race snapshot is truncated in the tracks");
    std::vector<Waypoint> wp;
    for (std::int64_t k = 0; k < n; k += 4) wp.push_back({{w[k], w[k + 1], w[k + 2]}, w[k + 3]});
    tracks_[e] = Track::from_waypoints(std::move(wp), config_.track.spacing_ft);
  }
  visit_arrays(*this, [&](const char* name, auto& v, Extent, auto) { get_vec(in, &v, name); });
}

}  // namespace f16race::race
