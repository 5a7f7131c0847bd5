#pragma once
// n_env independent two-team races stepped together on the batched F-16 simulator.
//
// Per LL step (12.5 Hz): actions [n_env, n_agent, 3] in [-1, 1] -> (throttle, Nz_ref, ps_ref)
// -> `substeps` RK4 steps -> progress, terminations, ranks, rewards -> finished races reset with
// a fresh track -> observations written in one pass into preallocated float buffers that a
// tensor can wrap without a copy. Every HL interval the caller picks 7-bin goal offsets per
// aircraft (set_hl_actions). Torch-free; see docs/race.md for every number and formula.
#include <array>
#include <cstdint>
#include <iosfwd>
#include <memory>
#include <memory_resource>
#include <string>
#include <vector>

#include "dynamics/f16_batch.hpp"
#include "dynamics/trim.hpp"
#include "race/huge_page_memory.hpp"
#include "race/observation_spec.hpp"
#include "race/race_config.hpp"
#include "random/random_stream.hpp"
#include "race/terminations.hpp"
#include "race/track.hpp"
#include "race/track_line.hpp"

namespace f16race::race {

// Observation widths and entries: race/observation_spec.hpp (kEgoDim, kAdoDim, kGoalDim).
inline constexpr int kActionDim = 3; // LL action: throttle, Nz_ref, ps_ref in [-1, 1]
inline constexpr int kHlDims = 3;    // HL action: bins for (d_north, d_east, d_up)
int task_dim(const RaceConfig& config);
int ado_dim(const RaceConfig& config);

// Why an aircraft leaves a race (TerminationCause, cause_name): race/terminations.hpp.

// Aggregates over the envs of one step (and of the races that ended in it).
struct StepStats {
  int terminations[kNumCauses] = {};  // per cause, aircraft taken out this step
  int races_finished = 0;             // races that ended this step
  int races_won[2] = {};              // by team (blue, red)
  int races_drawn = 0;
  int races_by_finish_line = 0;       // ended because an aircraft crossed the finish line
  int races_by_elimination = 0;       // ended because a whole team was out
  int races_by_time_limit = 0;
  int aircraft_alive_at_end = 0;      // over the races that ended this step
};

class RaceEnv {
 public:
  // `first_env_id`: these envs are [first_env_id, first_env_id + n_env) of a larger batch (one
  // rank's share of a distributed one): env e draws its tracks and starts from the stream
  // (seed, first_env_id + e), so the batch's races do not depend on how it is split.
  explicit RaceEnv(const RaceConfig& config, int first_env_id = 0);

  const RaceConfig& config() const { return config_; }
  int n_env() const { return config_.n_env; }
  int n_agent() const { return n_agent_; }
  int n_aircraft() const { return n_env() * n_agent_; }
  int task_dim() const { return task_dim_; }
  int ado_dim() const { return ado_dim_; }

  // Starts every race afresh (new tracks from each env's stream) and writes observations.
  void reset();
  // Starts env `env`'s next race now, its track and start drawn from the stream (seed,
  // stream_id) instead of the env's own: an evaluation that names its races (a tournament's
  // game k) gets the same race whichever env slot it lands in. The env's later auto-resets go
  // on from that stream. This step's outputs (env_done, causes, rewards) are left as they were.
  void start_race(int env, std::uint64_t stream_id);
  // Every env's stream becomes (seed, (salt << 32) + env id) for salt > 0: the races that begin
  // from here on draw other tracks and starts (a tail member's, train.tail_member); the races
  // under way go on.
  void reseed_streams(std::uint64_t salt);
  // Advances every env by one LL step. actions: [n_env, n_agent, 3] in [-1, 1] (clamped).
  StepStats step(const float* actions);
  // Sets HL goals for the envs whose hl_due() flag is up; others are ignored. bins: [n_env,
  // n_agent, 3] in [0, hl_bins). Rewrites those envs' goal observations.
  void set_hl_actions(const std::int64_t* bins);

  // --- observation buffers (row-major, float32, allocated once) ---
  const float* obs_ego() const { return ego_.data(); }            // [n_env, n_agent, kEgoDim]
  const float* obs_prev_action() const { return prev_action_.data(); }  // [n_env, n_agent, 3]
  const float* obs_goal() const { return goal_obs_.data(); }      // [n_env, n_agent, kGoalDim]
  const float* obs_ado() const { return ado_.data(); }            // [n_env, n_agent, n_agent-1, ado_dim]
  const std::uint8_t* obs_ado_alive() const { return ado_alive_.data(); }  // [n_env, n_agent, n_agent-1]
  const float* obs_task() const { return task_.data(); }          // [n_env, n_agent, task_dim]

  // --- per-step outputs ---
  const float* ll_reward() const { return ll_reward_.data(); }    // [n_env, n_agent]
  const float* hl_reward() const { return hl_reward_.data(); }    // [n_env, n_agent], this LL step's r_HL
  // 1 where the aircraft acted this step (was alive before it): the samples a learner keeps.
  const std::uint8_t* acted() const { return acted_.data(); }     // [n_env, n_agent]
  const std::uint8_t* terminated() const { return terminated_.data(); }  // [n_env, n_agent]
  const std::uint8_t* truncated() const { return truncated_.data(); }    // [n_env, n_agent] (time limit)
  // TerminationCause that took the aircraft out in this step (kCauseNone otherwise); kept when
  // the race ended and was reset in the same step.
  const std::int8_t* step_cause() const { return step_cause_.data(); }  // [n_env, n_agent]
  const std::uint8_t* hl_due() const { return hl_due_.data(); }   // [n_env]: call set_hl_actions
  const std::uint8_t* env_done() const { return env_done_.data(); }  // [n_env]: race ended (and was reset)
  // Where env_done: the winning team (0 blue, 1 red, -1 draw) and why the race ended.
  enum EndReason : std::int8_t { kEndNone = 0, kEndFinishLine = 1, kEndElimination = 2, kEndTimeLimit = 3 };
  const std::int8_t* race_winner() const { return race_winner_.data(); }  // [n_env]
  const std::int8_t* race_end() const { return race_end_.data(); }        // [n_env]
  double goal_distance_ft(int i) const { return goal_dist_ft_[i]; }
  // Observations of the final state of races that hit the time limit this step (rows of other
  // envs are stale): what a learner bootstraps a truncated episode from. Same shapes as obs_*.
  const float* final_ego() const { return final_ego_.data(); }
  const float* final_goal() const { return final_goal_.data(); }
  const float* final_prev_action() const { return final_prev_action_.data(); }
  const float* final_ado() const { return final_ado_.data(); }
  const std::uint8_t* final_ado_alive() const { return final_ado_alive_.data(); }
  const float* final_task() const { return final_task_.data(); }

  // --- state for tools, scripted pilots and tests ---
  const dynamics::F16Batch& sim() const { return sim_; }
  const Track& track(int env) const { return tracks_[env]; }
  // The race's racing line when goals are placed around one (race.goal_line_frac > 0), else null.
  const TubeLine* racing_line(int env) const { return lines_.empty() ? nullptr : &lines_[env]; }
  const std::vector<TubeLine>& racing_lines() const { return lines_; }  // [n_env], or empty
  double race_time_s(int env) const { return time_s_[env]; }
  bool alive(int i) const { return alive_[i] != 0; }
  int cause(int i) const { return cause_[i]; }
  double progress_ft(int i) const { return progress_ft_[i]; }
  double lateral_ft(int i) const { return lateral_ft_[i]; }
  double vertical_ft(int i) const { return vertical_ft_[i]; }
  int ego_rank(int i) const { return ego_rank_[i]; }
  // The same per-aircraft state as arrays [n_env, n_agent] (race time [n_env]), for passes over
  // every aircraft (race/block_events).
  const double* progress_ft_data() const { return progress_ft_.data(); }
  const double* lateral_ft_data() const { return lateral_ft_.data(); }
  const double* vertical_ft_data() const { return vertical_ft_.data(); }
  const std::uint8_t* alive_data() const { return alive_.data(); }
  const double* race_time_s_data() const { return time_s_.data(); }
  double team_rank(int i) const { return team_rank_[i]; }
  const Vec3& goal_point(int i) const { return goal_point_[i]; }
  // Where the goal is along the track, and its lane: offsets in the tube cross-section there [ft].
  double goal_progress_ft(int i) const { return goal_progress_ft_[i]; }
  double goal_lateral_ft(int i) const { return goal_lateral_ft_[i]; }
  double goal_vertical_ft(int i) const { return goal_vertical_ft_[i]; }
  // The HL bins [3] aircraft i's goal was last placed with (the middle bins after a reset).
  const std::int64_t* goal_bins(int i) const { return &goal_bins_[static_cast<std::size_t>(i) * kHlDims]; }
  // Start offsets in the tube cross-section (used by the scripted pilot to keep its lane).
  double start_lateral_ft(int i) const { return start_lateral_ft_[i]; }
  double start_vertical_ft(int i) const { return start_vertical_ft_[i]; }
  static int team_of(int agent, int team_size) { return agent < team_size ? 0 : 1; }

  // For tools and tests: write access to the simulator, then refresh() recomputes track
  // geometry, ranks and observations from the current states without stepping.
  dynamics::F16Batch& mutable_sim() { return sim_; }
  void refresh();

  // Exact snapshot of the whole env (simulator, tracks, random streams, race state, buffers), so
  // a resumed training run continues bit-identically. load_state checks the shapes and throws
  // std::runtime_error on a mismatch or a truncated stream.
  void save_state(std::ostream& out) const;
  void load_state(std::istream& in);
  // The listed arrays of a snapshot, in its order (for tests and for reading a snapshot by hand).
  struct SnapshotArray {
    std::string name;
    std::size_t elements = 0, bytes = 0;
  };
  std::vector<SnapshotArray> snapshot_layout() const;

 private:
  // How long a listed array is: per env, per aircraft, or one of the observation buffers.
  enum class Extent { env, aircraft, aircraft_hl, obs_ego, obs_action, obs_goal, obs_ado, obs_ado_rows, obs_task };
  std::size_t extent_size(Extent x) const;

  // Every per-env and per-aircraft array after the simulator, the random streams and the tracks:
  // its snapshot name (a short or mismatched snapshot is reported by it), its length and its value
  // after construction. The one list the constructor sizes from and save_state / load_state walk,
  // in snapshot order: a new field is its declaration plus one line here.
  template <class Self, class F>
  static void visit_arrays(Self& s, F&& f) {
    using X = Extent;
    f("time", s.time_s_, X::env, 0.0); f("hl timer", s.hl_time_left_s_, X::env, 0.0);
    f("hl due", s.hl_due_, X::env, 1); f("env done", s.env_done_, X::env, 0);
    f("alive", s.alive_, X::aircraft, 0); f("acted", s.acted_, X::aircraft, 0);
    f("terminated", s.terminated_, X::aircraft, 0); f("truncated", s.truncated_, X::aircraft, 0);
    f("cause", s.cause_, X::aircraft, kCauseNone); f("step cause", s.step_cause_, X::aircraft, kCauseNone);
    f("track hint", s.track_hint_, X::aircraft, -1); f("ego rank", s.ego_rank_, X::aircraft, 0);
    f("previous ego rank", s.prev_ego_rank_, X::aircraft, 0); f("progress", s.progress_ft_, X::aircraft, 0.0);
    f("lateral", s.lateral_ft_, X::aircraft, 0.0); f("vertical", s.vertical_ft_, X::aircraft, 0.0);
    f("distance", s.dist_ft_, X::aircraft, 0.0); f("radius", s.radius_ft_, X::aircraft, 1.0);
    f("tube timer", s.tube_out_s_, X::aircraft, 0.0); f("team rank", s.team_rank_, X::aircraft, 0.0);
    f("goal distance", s.goal_dist_ft_, X::aircraft, 0.0);
    f("start lateral", s.start_lateral_ft_, X::aircraft, 0.0);
    f("start vertical", s.start_vertical_ft_, X::aircraft, 0.0);
    f("goal point", s.goal_point_, X::aircraft, Vec3{});
    f("goal progress", s.goal_progress_ft_, X::aircraft, 0.0);
    f("goal lateral", s.goal_lateral_ft_, X::aircraft, 0.0);
    f("goal vertical", s.goal_vertical_ft_, X::aircraft, 0.0);
    f("goal bins", s.goal_bins_, X::aircraft_hl, s.config_.hl_center_bin());
    f("ego obs", s.ego_, X::obs_ego, 0.0f); f("prev action obs", s.prev_action_, X::obs_action, 0.0f);
    f("goal obs", s.goal_obs_, X::obs_goal, 0.0f); f("ado obs", s.ado_, X::obs_ado, 0.0f);
    f("task obs", s.task_, X::obs_task, 0.0f); f("ado alive", s.ado_alive_, X::obs_ado_rows, 0);
    f("ll reward", s.ll_reward_, X::aircraft, 0.0f); f("hl reward", s.hl_reward_, X::aircraft, 0.0f);
    f("race winner", s.race_winner_, X::env, -1); f("race end", s.race_end_, X::env, 0);
  }

  // The step and its systems, each in the file named after it: race_env.cpp (actions, track
  // geometry, ranks), terminations.cpp (collisions.cpp), goals.cpp, rewards.cpp, race_end.cpp, resets.cpp,
  // observations.cpp.
  void apply_actions(int i0, int i1, const float* actions);
  std::array<float, kActionDim> action_of(const dynamics::TrimResult& trim) const;  // in action units
  void prefetch_track(int env) const;
  void step_env(int env);  // race logic, rewards, resets and observations after the flight step
  void reset_env(int env);
  void update_track_geometry(int env);
  void compute_ranks(int env);
  // new_cause: [n_agent] the step's causes (kCauseNone: still racing) take their aircraft out.
  void take_out(int env, const std::int8_t* new_cause);
  // progress_before_ft: [n_agent] each aircraft's progress before the step.
  void pay_rewards(int env, const double* progress_before_ft);
  // Ends env's race if it is over (outcome, stats, final flags, the next race); false: it goes on.
  bool end_race_if_over(int env);
  void write_observations(int env);
  // The track preview and task entries; cos_psi, sin_psi: [n_agent] the env's headings.
  void write_task_observations(int env, const float* cos_psi, const float* sin_psi);
  void write_goal_observation(int i);
  double goal_lane_error_ft(int i) const;
  // The lane aircraft i's goal asks for, at the aircraft's own cross-section: the goal's offsets,
  // moved along with the racing line when goals are placed on one (race.goal_line_frac).
  void goal_lane_here(int i, double* right_ft, double* up_ft) const;
  // Env's racing line for its race, when race.goal_line_frac > 0 (after a reset or a load).
  void compute_racing_line(int env);
  // Places again at the horizon, with the same bins, the goals their live aircraft have (nearly) reached.
  void refresh_reached_goals(int env);
  // Pushes apart, across the track, the goals of env's live teammates closer than
  // race.goal_min_separation_ft; mover >= 0: only that aircraft's goal moves (a refresh).
  void separate_goals(int env, int mover);
  // Moves aircraft i's goal across the track at its goal point, inside the outer bins' radius.
  void shift_goal(int i, double right_ft, double up_ft);
  // Penalty weight of the step for the teammates within race.separation_ft of aircraft i.
  double separation_penalty(int i) const;
  // At a decision, and again at the horizon when the goal is (nearly) reached (goal_refresh_ft).
  void place_goal(int i, const std::int64_t* bins3);

  RaceConfig config_;
  int n_agent_;
  int task_dim_;
  int ado_dim_;
  dynamics::F16Batch sim_;
  std::vector<dynamics::TrimResult> trims_;  // level trims at start_speed every trim_step_ft
  double trim_alt0_ft_ = 0.0, trim_step_ft_ = 50.0;

  // Per env. Every track's samples live in one huge-page block, a fixed slice per env.
  std::unique_ptr<HugePageMemory> track_memory_;
  std::vector<std::unique_ptr<std::pmr::monotonic_buffer_resource>> track_slices_;
  std::vector<Track> tracks_;
  std::vector<TubeLine> lines_;  // [n_env] the racing lines (race.goal_line_frac > 0), else empty
  std::vector<RandomStream> rng_;
  int first_env_id_ = 0;
  std::vector<double> time_s_, hl_time_left_s_;
  std::vector<std::uint8_t> hl_due_, env_done_;
  std::vector<std::int8_t> race_winner_, race_end_;

  // Per aircraft [n_env * n_agent].
  std::vector<std::uint8_t> alive_, acted_, terminated_, truncated_;
  std::vector<std::int8_t> cause_, step_cause_;
  std::vector<int> track_hint_, ego_rank_, prev_ego_rank_;
  std::vector<double> progress_ft_, lateral_ft_, vertical_ft_, dist_ft_, radius_ft_;
  std::vector<double> tube_out_s_, team_rank_, goal_dist_ft_;
  std::vector<double> start_lateral_ft_, start_vertical_ft_;
  std::vector<Vec3> goal_point_;
  std::vector<double> goal_progress_ft_;   // [N] center-line progress of the goal's point
  std::vector<double> goal_lateral_ft_, goal_vertical_ft_;  // [N] the goal's offset in its tube cross-section
  std::vector<std::int64_t> goal_bins_;    // [N, 3] the HL bins the goal was placed with

  // Outputs. The observation buffers (megabytes, rewritten every step) share one huge-page
  // block like the tracks.
  std::unique_ptr<HugePageMemory> obs_memory_;
  std::unique_ptr<std::pmr::monotonic_buffer_resource> obs_slice_;
  std::pmr::vector<float> ego_, prev_action_, goal_obs_, ado_, task_;
  std::pmr::vector<std::uint8_t> ado_alive_;
  std::vector<float> ll_reward_, hl_reward_;
  std::vector<StepStats> step_stats_;  // [n_env], reused every step
  std::pmr::vector<float> final_ego_, final_goal_, final_prev_action_, final_ado_, final_task_;
  std::pmr::vector<std::uint8_t> final_ado_alive_;
  void copy_final_observations(int env);
};

}  // namespace f16race::race
