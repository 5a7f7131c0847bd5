#include "race/race_config.hpp"

#include <cmath>
#include <cstdio>

#include "dynamics/engine.hpp"
#include "io/csv_table.hpp"
#include "io/yaml_config.hpp"

namespace f16race::race {

namespace {
// Samples of one track, held for every race at once (~120 bytes each): beyond this a typo.
constexpr double kMaxTrackSamples = 1e7;

std::string short_count(double x) {
  char buf[32];
  std::snprintf(buf, sizeof buf, "%.3g", x);
  return buf;
}

// race.track: the random tube tracks.
template <class R>
void bind_track_keys(R& r, RaceConfig* c) {
  auto t = r.child("track");
  t.read("n_waypoints", &c->track.n_waypoints, 4, 1000);
  t.read("leg_min_ft", &c->track.leg_min_ft, 500.0, 1e6);
  t.read("leg_max_ft", &c->track.leg_max_ft, 500.0, 1e6);
  t.read("max_turn_deg", &c->track.max_turn_deg, 0.0, 90.0);
  t.read("max_heading_dev_deg", &c->track.max_heading_dev_deg, 0.0, 89.0);
  t.read("max_climb_deg", &c->track.max_climb_deg, 0.0, 30.0);
  t.read("max_climb_change_deg", &c->track.max_climb_change_deg, 0.0, 30.0);
  t.read("alt_min_ft", &c->track.alt_min_ft, 0.0, 60000.0);
  t.read("alt_max_ft", &c->track.alt_max_ft, 0.0, 60000.0);
  t.read("radius_min_ft", &c->track.radius_min_ft, 50.0, 1e5);
  t.read("radius_max_ft", &c->track.radius_max_ft, 50.0, 1e5);
  t.read("spacing_ft", &c->track.spacing_ft, 1.0, 1000.0);
  t.finish();
}

// The start, the terminations and the envelope, the built-in pilots' settings, the LL commands.
template <class R>
void bind_start_and_limit_keys(R& r, RaceConfig* c) {
  r.read("start_s_ft", &c->start_s_ft, 0.0, 1e6);
  r.read("start_speed_ftps", &c->start_speed_ftps, 300.0, 1200.0);
  r.read("start_offset_frac", &c->start_offset_frac, 0.0, 0.95);
  r.read("start_min_separation_ft", &c->start_min_separation_ft, 0.0, 5000.0);
  r.read("finish_margin_ft", &c->finish_margin_ft, 0.0, 1e6);
  r.read("collision_radius_ft", &c->collision_radius_ft, 0.0, 5000.0);
  r.read("alt_min_ft", &c->alt_min_ft, -1000.0, 100000.0);
  r.read("alt_max_ft", &c->alt_max_ft, 0.0, 100000.0);
  r.read("nz_min_g", &c->nz_min_g, -20.0, 0.0);
  r.read("nz_max_g", &c->nz_max_g, 1.0, 20.0);
  r.read("turn_rate_max_dps", &c->turn_rate_max_dps, 1.0, 360.0);
  r.read("mach_max", &c->mach_max, 0.0, 3.0);
  r.read("mach_governor", &c->mach_governor);
  r.read("autopilot_airspeed_ftps", &c->autopilot_airspeed_ftps, 0.0, 3000.0);
  r.read("autopilot_shift_up_frac", &c->autopilot_shift_up_frac, -0.8, 0.8);
  std::string exit = c->tube_exit == TubeExit::kGrace ? "grace" : "terminate";
  r.read("tube_exit", &exit, {"grace", "terminate"});
  c->tube_exit = exit == "grace" ? TubeExit::kGrace : TubeExit::kTerminate;
  r.read("tube_grace_s", &c->tube_grace_s, 0.0, 3600.0);
  r.read("nz_ref_min_g", &c->nz_ref_min_g, -1.0, 6.0);
  r.read("nz_ref_max_g", &c->nz_ref_max_g, -1.0, 6.0);
  r.read("ps_ref_max_radps", &c->ps_ref_max_radps, 0.0, 10.0);
}

// The high level's goals and the low level's preview of the track.
template <class R>
void bind_goal_keys(R& r, RaceConfig* c) {
  r.read("hl_bins", &c->hl_bins, 1, 63);
  r.read("goal_ahead_ft", &c->goal_ahead_ft, 0.0, 1e6);
  r.read("goal_bin_scale", &c->goal_bin_scale, 0.0, 5.0);
  std::string frame = c->goal_frame == GoalFrame::kTrack ? "track" : "world";
  r.read("goal_frame", &frame, {"world", "track"});
  c->goal_frame = frame == "track" ? GoalFrame::kTrack : GoalFrame::kWorld;
  r.read("goal_refresh_ft", &c->goal_refresh_ft, 0.0, 1e6);
  r.read("goal_line_frac", &c->goal_line_frac, 0.0, 0.95);
  r.read("goal_shift_up_frac", &c->goal_shift_up_frac, -0.8, 0.8);
  r.read("preview_points", &c->preview_points, 1, 64);
  r.read("preview_spacing_ft", &c->preview_spacing_ft, 10.0, 1e5);
}

// The low level's reward weights.
template <class R>
void bind_reward_keys(R& r, RaceConfig* c) {
  r.read("w_goal_progress", &c->w_goal_progress, -1e6, 1e6);
  r.read("w_goal_proximity", &c->w_goal_proximity, -1e6, 1e6);
  r.read("goal_scale_ft", &c->goal_scale_ft, 1.0, 1e6);
  r.read("w_goal_lane", &c->w_goal_lane, -1e6, 1e6);
  r.read("goal_lane_scale_ft", &c->goal_lane_scale_ft, 1.0, 1e6);
  r.read("separation_ft", &c->separation_ft, 0.0, 1e5);
  r.read("w_separation", &c->w_separation, -1e6, 1e6);
  r.read("goal_min_separation_ft", &c->goal_min_separation_ft, 0.0, 1e5);
  r.read("w_tube", &c->w_tube, -1e6, 1e6);
  r.read("w_collision", &c->w_collision, -1e6, 1e6);
  r.read("w_termination", &c->w_termination, -1e6, 1e6);
  r.read("w_action_change", &c->w_action_change, -1e6, 1e6);
  r.read("w_rates", &c->w_rates, -1e6, 1e6);
}

// One list of keys for reading and writing: R is io::ConfigReader or io::ConfigWriter. The
// keys come in four groups; write_race_config writes them in this order.
template <class R>
void bind_race_config(R& r, RaceConfig* c) {
  r.read("n_env", &c->n_env, 1, 1 << 20);
  r.read("team_size", &c->team_size, 1, 8);
  std::string model = dynamics::aero_model_name(c->model);
  r.read("model", &model, {"morelli", "stevens"});
  dynamics::parse_aero_model(model.c_str(), &c->model);
  r.read("seed", &c->seed);
  r.read("dt_ll_s", &c->dt_ll_s, 0.001, 1.0);
  r.read("substeps", &c->substeps, 1, 1000);
  r.read("dt_hl_s", &c->dt_hl_s, 0.08, 600.0);
  r.read("time_limit_s", &c->time_limit_s, 1.0, 3600.0);
  r.read("time_limit_terminal", &c->time_limit_terminal);
  bind_track_keys(r, c);
  bind_start_and_limit_keys(r, c);
  bind_goal_keys(r, c);
  bind_reward_keys(r, c);
  r.finish();
}
}  // namespace

void read_race_config(io::ConfigReader& r, RaceConfig* c) {
  bind_race_config(r, c);
  validate_race_config(*c, r.source());
}

void write_race_config(io::ConfigWriter& w, RaceConfig c) { bind_race_config(w, &c); }

void validate_race_config(const RaceConfig& c, const std::string& source) {
  // Each message names the keys (under race:) with their values, and what would make them agree.
  auto fail = [&](const std::string& what) { throw io::ConfigError(source + ": race: " + what); };
  auto v = [](double x) { return io::format_double(x); };
  if (c.team_size < 1 || c.team_size > 8)
    fail("team_size (" + v(c.team_size) + ") must be in [1, 8] (1 vs 1 up to 8 vs 8)");
  if (c.n_env < 1) fail("n_env (" + v(c.n_env) + ") must be >= 1");
  if (c.dt_hl_s > c.time_limit_s)
    fail("dt_hl_s (" + v(c.dt_hl_s) + ") must be <= time_limit_s (" + v(c.time_limit_s) +
         "): a race must see at least one high-level interval end");
  if (c.track.leg_min_ft > c.track.leg_max_ft)
    fail("track.leg_min_ft (" + v(c.track.leg_min_ft) + ") must be <= track.leg_max_ft (" + v(c.track.leg_max_ft) + ")");
  if (c.track.alt_min_ft >= c.track.alt_max_ft)
    fail("track.alt_min_ft (" + v(c.track.alt_min_ft) + ") must be < track.alt_max_ft (" + v(c.track.alt_max_ft) + ")");
  if (c.track.radius_min_ft > c.track.radius_max_ft)
    fail("track.radius_min_ft (" + v(c.track.radius_min_ft) + ") must be <= track.radius_max_ft (" +
         v(c.track.radius_max_ft) + ")");
  // Every track is sampled every spacing_ft up front, for each race: a typo here asked for
  // gigabytes per race.
  // (Track::max_samples: the longest track the legs allow, with room for the turns' arcs.)
  const double samples = 1.5 * (c.track.n_waypoints - 1) * c.track.leg_max_ft / c.track.spacing_ft;
  if (samples > kMaxTrackSamples)
    fail("track.n_waypoints (" + v(c.track.n_waypoints) + "), track.leg_max_ft (" + v(c.track.leg_max_ft) +
         ") and track.spacing_ft (" + v(c.track.spacing_ft) + ") make tracks of up to " + short_count(samples) +
         " samples, more than " + short_count(kMaxTrackSamples) + "; raise track.spacing_ft or shorten the track");
  if (c.alt_min_ft >= c.alt_max_ft) fail("alt_min_ft (" + v(c.alt_min_ft) + ") must be < alt_max_ft (" + v(c.alt_max_ft) + ")");
  if (c.track.alt_min_ft - c.track.radius_max_ft < c.alt_min_ft || c.track.alt_max_ft + c.track.radius_max_ft > c.alt_max_ft)
    fail("the track band [track.alt_min_ft - track.radius_max_ft, track.alt_max_ft + track.radius_max_ft] = [" +
         v(c.track.alt_min_ft - c.track.radius_max_ft) + ", " + v(c.track.alt_max_ft + c.track.radius_max_ft) +
         "] must lie inside [alt_min_ft, alt_max_ft] = [" + v(c.alt_min_ft) + ", " + v(c.alt_max_ft) + "]");
  if (c.nz_ref_min_g >= c.nz_ref_max_g)
    fail("nz_ref_min_g (" + v(c.nz_ref_min_g) + ") must be < nz_ref_max_g (" + v(c.nz_ref_max_g) + ")");
  if (c.hl_bins % 2 == 0) fail("hl_bins (" + v(c.hl_bins) + ") must be odd so that the middle bin is the center-line");
  if (c.mach_max > 0.0 && c.mach_max < 0.2) fail("mach_max (" + v(c.mach_max) + ") must be 0 (no limit) or >= 0.2");
  if (c.autopilot_airspeed_ftps != 0.0 && c.autopilot_airspeed_ftps < 300.0)
    fail("autopilot_airspeed_ftps (" + v(c.autopilot_airspeed_ftps) + ") must be 0 (the start speed) or >= 300 ft/s");
  if (c.mach_governor && c.mach_max == 0.0) fail("mach_governor needs a mach_max > 0 to hold the aircraft below");
  if (c.mach_max > 0.0) {  // the highest start: the slowest speed of sound, so the start's highest Mach
    const double highest_ft = c.track.alt_max_ft + c.track.radius_max_ft;
    const double start_mach = dynamics::air_data(c.start_speed_ftps, highest_ft).mach;
    if (start_mach > c.mach_max - 0.01 - kGovernorBandMach)  // the start lies below the governor's band
      fail("start_speed_ftps (" + v(c.start_speed_ftps) + ") is Mach " + v(std::round(start_mach * 1000.0) / 1000.0) +
           " at " + v(highest_ft) + " ft, too close to mach_max (" + v(c.mach_max) + "): start slower (or raise mach_max)");
  }
  if (c.goal_refresh_ft >= c.goal_ahead())
    fail("goal_refresh_ft (" + v(c.goal_refresh_ft) + ") must be < goal_ahead_ft (" + v(c.goal_ahead()) +
         (c.goal_ahead_ft > 0.0 ? "" : ": 0, so the preview horizon preview_points x preview_spacing_ft") +
         "), else the goal would be placed again at every step");
  if (c.start_s_ft + c.finish_margin_ft + 1000.0 > c.track.leg_min_ft * (c.track.n_waypoints - 1))
    fail("start_s_ft (" + v(c.start_s_ft) + ") + finish_margin_ft (" + v(c.finish_margin_ft) +
         ") leaves no race on the shortest possible track (track.leg_min_ft x (track.n_waypoints - 1) = " +
         v(c.track.leg_min_ft * (c.track.n_waypoints - 1)) + " ft; at least 1000 ft of it must be raced)");
}

}  // namespace f16race::race
