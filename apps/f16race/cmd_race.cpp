// `f16race race`: run races with a built-in pilot, write every aircraft's trajectory and a
// figure in the style of the paper's Fig. 4 (forward displacement vs lateral offset and vs
// height in the tube, tube boundary drawn, teams coloured).
#include <CLI/CLI.hpp>
#include <cmath>
#include <cstdio>
#include <filesystem>
#include <memory>
#include <string>
#include <vector>

#include "commands.hpp"
#include "io/csv_table.hpp"
#include "io/plot.hpp"
#include "io/yaml_config.hpp"
#include "race/race_env.hpp"
#include "race/scripted_pilot.hpp"

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
};

// Trajectory rows of one race: [agent] -> columns t, s, lat, vert, pn, pe, alt, vt, phi, radius.
struct RaceRecord {
  std::vector<std::vector<std::vector<double>>> by_agent;
  bool done = false;
  std::string end_reason;
  int winner = -1;  // 0 blue, 1 red, -1 draw
  double duration_s = 0.0;
  int alive_at_end = 0;
  std::vector<int> causes;  // per agent
};

void plot_race(const RaceEnv& env, const RaceRecord& rec, int race_id, const std::string& dir) {
  const int n_agent = env.n_agent();
  const std::vector<std::string> header{"t_s", "s_ft", "lateral_ft", "vertical_ft", "pn_ft", "pe_ft",
                                        "alt_ft", "vt_ftps", "phi_rad", "radius_ft"};
  io::PlotPanel lat{"Lateral offset in the tube", "forward displacement along the track [ft]", "lateral [ft] (+ right)", {}, ""};
  io::PlotPanel ver{"Vertical offset in the tube", "forward displacement along the track [ft]", "vertical [ft] (+ up)", {}, ""};
  // Tube boundary: +-radius along the part of the track the race covered.
  std::vector<std::vector<double>> tube(3);
  double s_max = 0.0;
  for (const auto& rows : rec.by_agent)
    for (const auto& r : rows) s_max = std::max(s_max, r[1]);
  for (const auto& rows : rec.by_agent) {
    for (const auto& r : rows) {
      tube[0].push_back(r[1]);
      tube[1].push_back(r[9]);
      tube[2].push_back(-r[9]);
    }
    break;
  }
  const std::string tube_file = "race" + std::to_string(race_id) + "_tube.csv";
  io::write_csv(dir + "/" + tube_file, {"s_ft", "plus_radius_ft", "minus_radius_ft"}, tube);
  for (io::PlotPanel* p : {&lat, &ver}) {
    p->series.push_back({tube_file, "1:2", "lines lw 2 lc rgb '#e6b800'", "tube boundary", ""});
    p->series.push_back({tube_file, "1:3", "lines lw 2 lc rgb '#e6b800'", "", ""});
  }
  const char* blues[] = {"#08306b", "#2171b5", "#4292c6", "#6baed6", "#9ecae1", "#0b559f", "#3b7dd8", "#89bde6"};
  const char* reds[] = {"#67000d", "#cb181d", "#ef3b2c", "#fb6a4a", "#fc9272", "#a50f15", "#e34a33", "#fdae91"};
  for (int a = 0; a < n_agent; ++a) {
    const auto& rows = rec.by_agent[a];
    std::vector<std::vector<double>> cols(header.size());
    for (const auto& r : rows)
      for (std::size_t c = 0; c < header.size(); ++c) cols[c].push_back(r[c]);
    const std::string file = "race" + std::to_string(race_id) + "_agent" + std::to_string(a) + ".csv";
    io::write_csv(dir + "/" + file, header, cols);
    const int team = RaceEnv::team_of(a, env.config().team_size);
    const std::string color = team == 0 ? blues[a % 8] : reds[a % 8];
    const std::string title = std::string(team == 0 ? "blue " : "red ") + std::to_string(a);
    lat.series.push_back({file, "2:3", "lines lw 1.5 lc rgb '" + color + "'", title, ""});
    ver.series.push_back({file, "2:4", "lines lw 1.5 lc rgb '" + color + "'", "", ""});
  }
  io::PlotSpec spec;
  spec.output = dir + "/race" + std::to_string(race_id) + ".png";
  spec.rows = 2;
  spec.title = "Race " + std::to_string(race_id) + ": " + rec.end_reason;
  spec.panels = {lat, ver};
  std::string msg;
  if (io::render_plot(spec, dir + "/race" + std::to_string(race_id) + ".gp", &msg)) std::printf("figure: %s\n", msg.c_str());
  else std::printf("figure not drawn: %s\n", msg.c_str());
}

void run_race(const RaceOptions& o) {
  YAML::Node root = io::load_yaml_file(o.config);
  for (const std::string& s : o.overrides) io::apply_override(root, s);
  RaceConfig cfg;
  io::ConfigReader top(root, o.config);
  io::ConfigReader rr = top.child("race");
  read_race_config(rr, &cfg);
  cfg.n_env = o.races;
  if (o.seed >= 0) cfg.seed = static_cast<std::uint64_t>(o.seed);
  if (o.policy != "scripted") throw UserError("--policy '" + o.policy + "': only 'scripted' is built in so far");

  RaceEnv env(cfg);
  const int n = env.n_aircraft(), n_agent = env.n_agent();
  std::filesystem::create_directories(o.out);
  for (int e = 0; e < cfg.n_env; ++e) env.track(e).save_csv(o.out + "/race" + std::to_string(e) + "_track.csv");

  std::vector<RaceRecord> recs(cfg.n_env);
  for (RaceRecord& r : recs) r.by_agent.resize(n_agent);
  std::vector<float> actions(static_cast<std::size_t>(n) * kActionDim);
  std::vector<std::int64_t> bins(static_cast<std::size_t>(n) * kHlDims, cfg.hl_bins / 2);
  ScriptedPilotConfig pilot;
  pilot.speed_ftps = cfg.start_speed_ftps;
  int remaining = cfg.n_env;
  StepStats totals;
  auto record = [&](int e) {
    for (int a = 0; a < n_agent; ++a) {
      const int i = e * n_agent + a;
      if (!env.alive(i)) continue;
      const auto& sim = env.sim();
      recs[e].by_agent[a].push_back({env.race_time_s(e), env.progress_ft(i), env.lateral_ft(i), env.vertical_ft(i),
                                     sim.state(dynamics::kPn)[i], sim.state(dynamics::kPe)[i],
                                     sim.state(dynamics::kAlt)[i], sim.state(dynamics::kVt)[i],
                                     sim.state(dynamics::kPhi)[i], env.track(e).radius_at(env.progress_ft(i))});
    }
  };
  for (int e = 0; e < cfg.n_env; ++e) record(e);
  std::vector<int> last_cause(n, 0);
  for (long step = 0; remaining > 0; ++step) {
    env.set_hl_actions(bins.data());
    scripted_actions(env, pilot, actions.data());
    std::vector<double> t_before(cfg.n_env);
    for (int e = 0; e < cfg.n_env; ++e) t_before[e] = env.race_time_s(e);
    const StepStats st = env.step(actions.data());
    for (int e = 0; e < cfg.n_env; ++e) {
      RaceRecord& r = recs[e];
      if (r.done) continue;
      for (int a = 0; a < n_agent; ++a) {
        const int i = e * n_agent + a;
        if (env.step_cause()[i] != kCauseNone) last_cause[i] = env.step_cause()[i];
      }
      if (env.env_done()[e]) {
        r.done = true;
        --remaining;
        r.duration_s = t_before[e] + cfg.dt_ll_s;
        // The env has already been reset for its next race; the end flags say how this one ended.
        int alive = 0;
        for (int a = 0; a < n_agent; ++a) {
          const int i = e * n_agent + a;
          const bool survived = last_cause[i] == kCauseNone;
          alive += survived;
          r.causes.push_back(last_cause[i]);
        }
        r.alive_at_end = alive;
        r.winner = env.race_winner()[e];
        const int end = env.race_end()[e];
        r.end_reason = end == RaceEnv::kEndFinishLine ? "finish line" : (end == RaceEnv::kEndElimination ? "elimination" : "time limit");
        continue;
      }
      record(e);
    }
    totals.races_by_finish_line += st.races_by_finish_line;
    for (int k = 0; k < kNumCauses; ++k) totals.terminations[k] += st.terminations[k];
    (void)step;
  }
  // Per-race summary (winner and end reason as the env decided them).
  std::vector<std::vector<double>> cols(5);
  std::vector<std::string> reasons;
  std::vector<std::vector<std::string>> scols(1);
  int alive_total = 0;
  for (int e = 0; e < cfg.n_env; ++e) {
    RaceRecord& r = recs[e];
    alive_total += r.alive_at_end;
    cols[0].push_back(e);
    cols[1].push_back(r.duration_s);
    cols[2].push_back(r.winner);
    cols[3].push_back(r.alive_at_end);
    cols[4].push_back(env.track(e).length_ft());
    reasons.push_back(r.end_reason);
    std::string causes;
    for (int a = 0; a < n_agent; ++a) causes += (a ? ";" : "") + std::string(cause_name(r.causes[a]));
    scols[0].push_back(causes);
  }
  scols.push_back(reasons);
  io::write_csv(o.out + "/races.csv", {"race", "duration_s", "winner_team", "alive_at_end", "track_length_ft"}, cols,
                {"terminations", "end"}, scols);
  std::printf("%d races (%d vs %d, %s pilot, seed %llu): %d of %d aircraft alive at the end\n", cfg.n_env,
              cfg.team_size, cfg.team_size, o.policy.c_str(), static_cast<unsigned long long>(cfg.seed), alive_total,
              cfg.n_env * n_agent);
  std::printf("terminations:");
  for (int k = 1; k < kNumCauses; ++k) std::printf(" %s %d", cause_name(k), totals.terminations[k]);
  std::printf("\ntrajectories and tracks: %s/\n", o.out.c_str());
  if (o.plot_race >= 0 && o.plot_race < cfg.n_env) plot_race(env, recs[o.plot_race], o.plot_race, o.out);
}

}  // namespace

void add_race_command(CLI::App& app) {
  auto o = std::make_shared<RaceOptions>();
  CLI::App* cmd = app.add_subcommand("race", "Run races with a built-in pilot; write trajectories and a Fig. 4-style plot");
  cmd->add_option("--config", o->config, "YAML config (its race: section is used)");
  cmd->add_option("--set", o->overrides, "Override a config key, e.g. --set race.team_size=2 (repeatable)");
  cmd->add_option("--policy", o->policy, "Pilot: scripted (fly the tube, keep your lane)");
  cmd->add_option("--races", o->races, "Number of races (run in parallel)")->check(CLI::Range(1, 100000));
  cmd->add_option("--seed", o->seed, "Seed (default: the config's race.seed)");
  cmd->add_option("--plot", o->plot_race, "Which race to draw (-1: none)");
  cmd->add_option("--out", o->out, "Output folder");
  cmd->callback([o]() { run_race(*o); });
}

}  // namespace f16race::app
