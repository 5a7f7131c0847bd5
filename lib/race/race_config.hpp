#pragma once
// Everything that defines a race, with the defaults documented in docs/race.md. Plain struct;
// read_race_config() fills it from the `race:` section of a YAML config and validates it.
#include <cstdint>
#include <string>

#include "dynamics/state.hpp"
#include "race/track.hpp"

namespace f16race::io {
class ConfigReader;
class ConfigWriter;
}

namespace f16race::race {

enum class TubeExit { kTerminate, kGrace };
// Axes of the HL goal offsets: world north/east/up (the paper's d_pn, d_pe, d_pa) or the track
// frame at the goal (along, right, up), where each axis is one kind of lane change.
enum class GoalFrame { kWorld, kTrack };

// The middle bin of an HL axis (the center-line lane): the neutral HL action, in one place.
constexpr int center_hl_bin(int hl_bins) { return hl_bins / 2; }

// The Mach governor's band (RaceConfig::mach_governor). A quarter as wide left too little margin
// for a dive: the pilots held the throttle back.
inline constexpr double kGovernorBandMach = 0.04;

// The defaults are the main job's race (configs/default.yaml lists them; a test holds the two
// equal): a config or RaceEnv() that leaves a key out gets the value here.
struct RaceConfig {
  int n_env = 32;
  int team_size = 4;                 // aircraft per team; two teams, blue (0) and red (1)
  dynamics::AeroModel model = dynamics::AeroModel::kMorelli;
  std::uint64_t seed = 1;

  // Timing (paper: LL control at 12.5 Hz, HL every 8 s or 20 s).
  double dt_ll_s = 0.08;
  int substeps = 8;                  // RK4 steps per LL step: 0.01 s
  double dt_hl_s = 8.0;
  double time_limit_s = 60.0;       // short races, so that finishing is learnable in minutes
  // The race really ends at the time limit (time left is observed), so by default reaching it
  // is a termination for both levels; false reports it as a truncation (bootstrapped).
  bool time_limit_terminal = true;

  TrackConfig track;

  // Start: same forward displacement for all, random offsets inside the tube, level trim.
  double start_s_ft = 1500.0;
  // Inside the envelope (mach_max) at every start altitude; AeroBench's own examples fly ~540.
  double start_speed_ftps = 560.0;
  double start_offset_frac = 0.6;    // offsets drawn within this fraction of the tube radius
  double start_min_separation_ft = 300.0;
  double finish_margin_ft = 1500.0;  // finish line this far before the end of the center-line

  // Terminations.
  double collision_radius_ft = 60.0;
  double alt_min_ft = 1000.0;
  double alt_max_ft = 40000.0;
  double nz_min_g = -3.0;            // structural load limits on AeroBench's Nz
  double nz_max_g = 9.0;
  double turn_rate_max_dps = 40.0;   // heading rate; beyond this the manoeuvre is not realistic
  // The aero data (NASA TP-1538 wind-tunnel data, fitted by Stevens & Lewis' tables and Morelli's
  // polynomials) are low-speed data with no Mach terms: an aircraft above mach_max is out
  // (cause "envelope"; 0: no limit). docs/race.md "The envelope" gives the sources.
  double mach_max = 0.6;
  // A governor in the fly-by-wire throttle path keeps the aircraft below mach_max: the throttle
  // the policy commands is capped, from full below mach_max - 0.01 - kGovernorBandMach to idle
  // at mach_max - 0.01. The cap is proportional: an aircraft settles kGovernorBandMach x its
  // throttle below the top, so one with more drag settles lower.
  bool mach_governor = true;
  // The `autopilot` baseline's airspeed set point (tournament, replay, race); 0: start_speed_ftps.
  // Tuned over set points against the start speed (docs/race.md "The autopilot baseline").
  double autopilot_airspeed_ftps = 640.0;
  // Its aim points moved up by this fraction of the local tube radius (negative: down), held
  // within 0.8 R. Under the Mach governor lower air is faster: tuned over heights, 0.3 R down is
  // the autopilot's best (docs/race.md "The autopilot baseline"); 0 keeps the start lanes.
  double autopilot_shift_up_frac = -0.3;
  TubeExit tube_exit = TubeExit::kGrace;
  double tube_grace_s = 3.0;         // time allowed outside the tube before termination

  // LL action mapping from [-1, 1]: throttle [0, 1], Nz_ref [nz_ref_min, nz_ref_max] g,
  // ps_ref [-ps_ref_max, ps_ref_max] rad/s; Ny_r_ref is 0 (paper, following AeroBench).
  double nz_ref_min_g = -1.0;
  double nz_ref_max_g = 6.0;
  double ps_ref_max_radps = 2.5;

  // HL goals: 7 bins per axis around the center-line point goal_ahead_ft ahead; the outer bins
  // sit at goal_bin_scale x the local tube radius. goal_ahead_ft 0 puts the point at the end of
  // the preview horizon (paper Sec. IV-B): preview_points x preview_spacing_ft.
  int hl_bins = 7;
  double goal_ahead_ft = 0.0;
  double goal_bin_scale = 0.8;
  // Track: measured to win more, and more reliably, than world axes (docs/learning.md, "Goal axes").
  GoalFrame goal_frame = GoalFrame::kTrack;
  // A goal the aircraft comes within this far of (along the track) is placed again at the
  // horizon with the same bins, so a long HL interval (20 s covers ~16 000 ft) keeps a goal
  // ahead instead of one it has flown past. 0: never.
  double goal_refresh_ft = 3000.0;
  // > 0: the goals' bins are offsets from the team's racing line instead of the center-line (the
  // middle bin on the line): the taut line through the tube from the start to the finish line,
  // each point within this fraction of the local radius (race/track_line.hpp), computed once per
  // race. A goal stays within goal_bin_scale x the radius. 0: the center-line (the paper's).
  double goal_line_frac = 0.25;
  // Every goal moved up by this fraction of the radius at the goal (negative: down), still within
  // goal_bin_scale x the radius: under the Mach governor lower air is faster.
  double goal_shift_up_frac = -0.3;

  // Observations.
  int preview_points = 6;
  double preview_spacing_ft = 2000.0;

  // LL reward weights (per LL step unless noted).
  double w_goal_progress = 1.0;      // closing speed toward the goal, per goal_scale_ft
  double w_goal_proximity = 0.05;    // exp(-distance / goal_scale_ft)
  double goal_scale_ft = 2000.0;
  // Lane: exp(-e / goal_lane_scale_ft), e the distance in the tube's cross-section between the
  // aircraft and its goal (the paper's "proximity reward for being close to the current
  // high-level waypoint", measured where the high level's offsets act: across the track).
  double w_goal_lane = 0.15;        // measured against 0.05: docs/learning.md
  double goal_lane_scale_ft = 500.0;
  // The proximity and lane terms are paid per foot of progress along the track, in units of the
  // start speed's step (start_speed_ftps x dt_ll_s): at that speed on the goal they pay what a
  // per-step term would, faster pays more, and time alone earns nothing (docs/race.md "Reward").
  // Teammates closer than separation_ft cost w_separation x (1 - d / separation_ft)^2 each, per
  // step: a gradient towards separation before the collision's one-off penalty.
  double separation_ft = 400.0;
  double w_separation = 0.5;
  // HL goals of teammates closer than this are pushed apart across the track (0: never), so a
  // team's decision never sends two aircraft to one point.
  double goal_min_separation_ft = 500.0;
  double w_tube = 0.5;               // per second outside the tube, scaled by how far outside
  double w_collision = 5.0;          // once, when taken out by a collision
  double w_termination = 5.0;        // once, for any other termination
  double w_action_change = 0.02;     // |a_t - a_{t-1}|^2
  double w_rates = 0.01;             // p^2 + q^2 + r^2 [rad^2/s^2]

  int n_agent() const { return 2 * team_size; }
  double autopilot_airspeed() const { return autopilot_airspeed_ftps > 0.0 ? autopilot_airspeed_ftps : start_speed_ftps; }
  // Distance of the goal's center-line point ahead of the aircraft [ft].
  double goal_ahead() const { return goal_ahead_ft > 0.0 ? goal_ahead_ft : preview_points * preview_spacing_ft; }
  // The middle bin on every HL axis: the center-line point itself.
  int hl_center_bin() const { return center_hl_bin(hl_bins); }
};

// Reads the `race:` section (absent keys keep defaults) and checks cross-field consistency.
// Throws io::ConfigError naming the file and key.
void read_race_config(io::ConfigReader& reader, RaceConfig* config);
// Writes every field (the resolved config of a run).
void write_race_config(io::ConfigWriter& writer, RaceConfig config);

// Checks the relations between fields that a single range cannot (e.g. nz_ref_min < nz_ref_max);
// throws io::ConfigError naming `source`.
void validate_race_config(const RaceConfig& config, const std::string& source);

}  // namespace f16race::race
