// `f16race race`: run races with a built-in pilot, write every aircraft's trajectory and a
// figure in the style of the paper's Fig. 4 (forward displacement vs lateral offset and vs
// height in the tube, tube boundary drawn, teams coloured).
#include <CLI/CLI.hpp>
#include <algorithm>
#include <cmath>
#include <cstdio>
#include <filesystem>
#include <memory>
#include <string>
#include <utility>
#include <vector>

#include "commands.hpp"
#include "config_versions/config_versions.hpp"
#include "io/csv_table.hpp"
#include "io/plot.hpp"
#include "io/yaml_config.hpp"
#include "race/race_env.hpp"
#include "race/race_recorder.hpp"
#include "race/scripted_pilot.hpp"
#include "race/track_line.hpp"

namespace f16race::app {
namespace {

using namespace f16race::race;

struct RaceOptions {
  std::string config = "configs/default.yaml";
  std::string policy = "scripted";
  std::string out = "runs/race";
  std::vector<std::string> overrides;
  int races = 4;
  long long seed = -1;
  int plot_race = 0;
  std::vector<double> airspeeds;  // the pilots' set points: one for all, or blue's and red's
  bool lines = false;             // also each track's shortest line (~20 ms a track)
  // The autopilot's racing line per team: its lanes shifted by the taut line whose points keep
  // within this fraction of the radius (0: its start lanes). One for both, or blue's and red's.
  std::vector<double> line_fracs;
  double line_max_offset = 1.0;  // a line's aim points held within this fraction of the radius
};

// The race config with the command line's overrides, checked before any race is flown.
RaceConfig race_config(const RaceOptions& o) {
  YAML::Node root = io::load_yaml_with_overrides(o.config, o.overrides);
  config_versions::migrate(root, o.config, config_versions::written_by(o.config));
  RaceConfig cfg;
  io::ConfigReader top(root, o.config);
  io::ConfigReader rr = top.child("race");
  read_race_config(rr, &cfg);
  cfg.n_env = o.races;
  if (o.seed >= 0) cfg.seed = static_cast<std::uint64_t>(o.seed);
  if (o.policy != "scripted" && o.policy != "autopilot")
    throw io::InputError("--policy '" + o.policy + "': use scripted or autopilot (AeroBench's waypoint autopilot)");
  if (o.plot_race >= cfg.n_env)  // never a silent "no figure"
    throw io::InputError("--plot " + std::to_string(o.plot_race) + ": there are " + std::to_string(cfg.n_env) +
                         " races (0 to " + std::to_string(cfg.n_env - 1) + "); draw one of them, or -1 for none");
  if (o.airspeeds.size() > 2) throw io::InputError("--airspeed: one set point for both teams, or blue's and red's");
  if (o.line_fracs.size() > 2) throw io::InputError("--racing-line: one radius fraction for both teams, or blue's and red's");
  if (!o.line_fracs.empty() && o.policy != "autopilot")
    throw io::InputError("--racing-line: only the autopilot flies a racing line; add --policy autopilot");
  return cfg;
}

// Every race to its end, each team flown by the chosen pilot at its set point (the one given,
// else the start speed for the scripted pilot and the autopilot's own).
StepStats fly_races(RaceEnv& env, const RaceConfig& cfg, const RaceOptions& o, RaceRecorder& rec) {
  const int n = env.n_aircraft(), n_agent = env.n_agent();
  std::vector<float> actions(static_cast<std::size_t>(n) * kActionDim);
  std::vector<std::int64_t> bins(static_cast<std::size_t>(n) * kHlDims, cfg.hl_center_bin());
  ScriptedPilotConfig pilot[2];
  AutopilotPilotConfig autopilot[2];
  std::vector<std::int64_t> rows[2];
  std::vector<TubeLine> lines[2];  // [n_env] per team that flies a racing line
  for (int team = 0; team < 2; ++team) {
    const double given = o.airspeeds.empty() ? 0.0 : o.airspeeds[std::min<std::size_t>(team, o.airspeeds.size() - 1)];
    pilot[team].speed_ftps = given > 0.0 ? given : cfg.start_speed_ftps;
    autopilot[team].airspeed_ftps = given > 0.0 ? given : cfg.autopilot_airspeed();
    const double frac = o.line_fracs.empty() ? 0.0 : o.line_fracs[std::min<std::size_t>(team, o.line_fracs.size() - 1)];
    if (frac > 0.0) {
      for (int e = 0; e < cfg.n_env; ++e) {  // each env's first race: the one recorded
        const Track& tr = env.track(e);
        lines[team].push_back(shortest_tube_line(tr, {cfg.start_s_ft, tr.length_ft() - cfg.finish_margin_ft, 1.0 - frac}));
      }
      autopilot[team].lines = &lines[team];
      autopilot[team].line_max_offset_frac = o.line_max_offset;
    }
    for (int i = 0; i < n; ++i)
      if (RaceEnv::team_of(i % n_agent, cfg.team_size) == team) rows[team].push_back(i);
  }
  StepStats totals;
  while (rec.remaining() > 0) {
    env.set_hl_actions(bins.data());  // center-line goals; the built-in pilots ignore them (none recorded)
    for (int team = 0; team < 2; ++team) {
      const auto nr = static_cast<std::int64_t>(rows[team].size());
      if (o.policy == "autopilot") autopilot_actions(env, autopilot[team], actions.data(), rows[team].data(), nr);
      else scripted_actions(env, pilot[team], actions.data(), rows[team].data(), nr);
    }
    rec.before_step(env);
    const StepStats st = env.step(actions.data());
    rec.after_step(env);
    totals.races_by_finish_line += st.races_by_finish_line;
    for (int k = 0; k < kNumCauses; ++k) totals.terminations[k] += st.terminations[k];
  }
  return totals;
}

// --lines: the race's stretch, start to finish line, measured three ways (center-line, the taut
// line in the tube, the taut line within half the radius): what the best line could save at
// equal speed. Appends the columns; returns the mean savings.
std::pair<double, double> add_line_columns(const RaceRecorder& rec, const RaceConfig& cfg,
                                           std::vector<std::string>* names, std::vector<std::vector<double>>* cols) {
  names->insert(names->end(), {"center_line_ft", "shortest_line_ft", "shortest_line_half_radius_ft"});
  cols->resize(cols->size() + 3);
  double saved = 0.0, saved_half = 0.0;
  const std::size_t c0 = cols->size() - 3;
  for (int e = 0; e < cfg.n_env; ++e) {
    const Track& track = rec.trace(e).track;
    const double s1 = track.length_ft() - cfg.finish_margin_ft;
    const TubeLine line = shortest_tube_line(track, {cfg.start_s_ft, s1});
    const TubeLine half = shortest_tube_line(track, {cfg.start_s_ft, s1, 0.5});
    (*cols)[c0].push_back(line.center_ft);
    (*cols)[c0 + 1].push_back(line.shortest_ft);
    (*cols)[c0 + 2].push_back(half.shortest_ft);
    saved += 1.0 - line.shortest_ft / line.center_ft;
    saved_half += 1.0 - half.shortest_ft / half.center_ft;
  }
  return {saved / cfg.n_env, saved_half / cfg.n_env};
}

// races.csv (winner and end reason as the env decided them) and the summary lines.
void report_races(const RaceEnv& env, const RaceConfig& cfg, const RaceOptions& o, const RaceRecorder& rec,
                  const StepStats& totals) {
  const int n_agent = env.n_agent();
  std::vector<std::string> names = {"race", "duration_s", "winner_team", "alive_at_end", "track_length_ft"};
  std::vector<std::vector<double>> cols(5);
  std::vector<std::string> reasons;
  std::vector<std::vector<std::string>> scols(1);
  int alive_total = 0, blue_wins = 0, draws = 0;
  for (int e = 0; e < cfg.n_env; ++e) {
    const RaceTrace& r = rec.trace(e);
    blue_wins += r.winner == 0;
    draws += r.winner < 0;
    const int alive = static_cast<int>(std::count(r.cause.begin(), r.cause.end(), static_cast<int>(kCauseNone)));
    alive_total += alive;
    cols[0].push_back(e);
    cols[1].push_back(r.duration_s);
    cols[2].push_back(r.winner);
    cols[3].push_back(alive);
    cols[4].push_back(r.track.length_ft());
    reasons.push_back(end_reason_name(r.end));
    std::string causes;
    for (int a = 0; a < n_agent; ++a) causes += (a ? ";" : "") + std::string(cause_name(r.cause[a]));
    scols[0].push_back(causes);
  }
  scols.push_back(reasons);
  std::pair<double, double> saved{};
  if (o.lines) saved = add_line_columns(rec, cfg, &names, &cols);
  io::write_csv(o.out + "/races.csv", names, cols, {"terminations", "end"}, scols);
  std::printf("%d races (%d vs %d, %s pilot, seed %llu): %d of %d aircraft alive at the end\n", cfg.n_env,
              cfg.team_size, cfg.team_size, o.policy.c_str(), static_cast<unsigned long long>(cfg.seed), alive_total,
              cfg.n_env * n_agent);
  std::printf("blue won %d, red %d, drawn %d\n", blue_wins, cfg.n_env - blue_wins - draws, draws);
  std::printf("terminations:");
  for (int k = 1; k < kNumCauses; ++k) std::printf(" %s %d", cause_name(k), totals.terminations[k]);
  std::printf("\n");
  if (o.lines)
    std::printf("shortest line through the tube, start to finish: %.2f %% shorter than the center-line (mean); "
                "within half the radius %.2f %%\n",
                100.0 * saved.first, 100.0 * saved.second);
  std::printf("trajectories and tracks: %s/\n", o.out.c_str());
}

// --plot: one race's trace as CSV, Tacview file and figure.
void plot_race(const RaceOptions& o, const RaceRecorder& rec) {
  const RaceTrace& t = rec.trace(o.plot_race);
  const std::string prefix = "race" + std::to_string(o.plot_race);
  write_trace_csv(t, o.out, prefix);
  write_trace_acmi(t, o.out + "/" + prefix + ".acmi", prefix + " (" + o.policy + " pilots)");
  std::string msg;
  if (plot_trace(t, o.out, prefix, "Race " + std::to_string(o.plot_race) + ": " + end_reason_name(t.end), &msg))
    std::printf("figure: %s\n", msg.c_str());
  else
    std::printf("figure not drawn: %s\n", msg.c_str());
}

void run_race(const RaceOptions& o) {
  const RaceConfig cfg = race_config(o);
  RaceEnv env(cfg);
  std::filesystem::create_directories(o.out);
  for (int e = 0; e < cfg.n_env; ++e) env.track(e).save_csv(o.out + "/race" + std::to_string(e) + "_track.csv");
  RaceRecorder rec(env);
  const StepStats totals = fly_races(env, cfg, o, rec);
  report_races(env, cfg, o, rec, totals);
  if (o.plot_race >= 0) plot_race(o, rec);
}

}  // namespace

void add_race_command(CLI::App& app) {
  auto o = std::make_shared<RaceOptions>();
  CLI::App* cmd = app.add_subcommand("race", "Run races with a built-in pilot; write trajectories and a Fig. 4-style plot");
  cmd->add_option("--config", o->config, "YAML config (its race: section is used)");
  cmd->add_option("--set", o->overrides, "Override a config key, e.g. --set race.team_size=2 (repeatable)");
  cmd->add_option("--policy", o->policy, "Pilot: scripted (fly the tube, keep your lane) or autopilot (AeroBench's waypoint autopilot on the same aim point)");
  cmd->add_option("--races", o->races, "Number of races (run in parallel)")->check(CLI::Range(1, 100000));
  cmd->add_option("--seed", o->seed, "Seed (default: the config's race.seed)")->check(kNonNegativeSeed);
  cmd->add_option("--plot", o->plot_race, "Which race to draw (-1: none)")->check(CLI::Range(-1, 100000));
  cmd->add_flag("--lines", o->lines, "Also measure each track's shortest line through the tube (races.csv; ~20 ms a track)");
  cmd->add_option("--out", o->out, "Output folder");
  cmd->add_option("--racing-line", o->line_fracs,
                  "The autopilot's lanes shifted by the taut line through the tube whose points keep within this "
                  "fraction of the local radius of the center-line: one for both teams, or blue's then red's "
                  "(default 0: the start lanes)")
      ->delimiter(',')
      ->check(CLI::Range(0.0, 1.0));
  cmd->add_option("--line-max-offset", o->line_max_offset,
                  "On a racing line, the aim point's offset from the center-line held within this fraction of the "
                  "local radius (default 1: not held)")
      ->check(CLI::Range(0.0, 1.0));
  cmd->add_option("--airspeed", o->airspeeds,
                  "The pilots' airspeed set point [ft/s]: one for both teams, or blue's then red's (default: the "
                  "start speed; the autopilot's race.autopilot_airspeed_ftps)")
      ->delimiter(',')
      ->check(CLI::Range(300.0, 3000.0));
  cmd->callback([o]() { run_race(*o); });
}

}  // namespace f16race::app
