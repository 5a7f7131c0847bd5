#include "race/race_recorder.hpp"

#include <algorithm>
#include <cmath>

#include "dynamics/inner_loop.hpp"
#include "dynamics/state.hpp"
#include "io/csv_table.hpp"
#include "io/plot.hpp"
#include "io/tacview.hpp"

namespace f16race::race {

RaceRecorder::RaceRecorder(const RaceEnv& env) : traces_(env.n_env()), t_before_(env.n_env(), 0.0), remaining_(env.n_env()) {
  const int n_agent = env.n_agent();
  for (int e = 0; e < env.n_env(); ++e) {
    RaceTrace& t = traces_[e];
    t.track = env.track(e);
    t.team_size = env.config().team_size;
    t.middle_bin = env.config().hl_center_bin();
    t.rows.resize(n_agent);
    t.goals.resize(n_agent);
    t.cause.assign(n_agent, kCauseNone);
    t.out_s.assign(n_agent, -1.0);
    record_rows(env, e);
  }
}

void RaceRecorder::record_rows(const RaceEnv& env, int e) {
  const auto& sim = env.sim();
  using namespace dynamics;
  for (int a = 0; a < env.n_agent(); ++a) {
    const int i = e * env.n_agent() + a;
    if (!env.alive(i)) continue;
    const double s = env.progress_ft(i);
    const float throttle_action = env.obs_prev_action()[static_cast<std::size_t>(i) * kActionDim];
    traces_[e].rows[a].push_back(TraceRow{env.race_time_s(e), s, env.lateral_ft(i), env.vertical_ft(i),
                                          sim.state(kPn)[i], sim.state(kPe)[i], sim.state(kAlt)[i], sim.state(kVt)[i],
                                          sim.state(kPhi)[i], sim.state(kTheta)[i], sim.state(kPsi)[i],
                                          traces_[e].track.radius_at(s), 0.5 * (throttle_action + 1.0),
                                          sim.ref(kThrottleDelta)[i] + lqr::kThrottleEquil, sim.state(kPow)[i],
                                          sim.state(kAlpha)[i]});
  }
}

void RaceRecorder::record_goals(const RaceEnv& env, const std::uint8_t* due, const std::uint8_t* agents) {
  for (int e = 0; e < env.n_env(); ++e) {
    RaceTrace& t = traces_[e];
    if (!due[e] || t.done) continue;
    for (int a = 0; a < env.n_agent(); ++a) {
      const int i = e * env.n_agent() + a;
      if (!env.alive(i) || (agents && !agents[a])) continue;
      const Vec3 p = env.goal_point(i);
      const TrackQuery q = t.track.project(p, -1);
      const std::int64_t* b = env.goal_bins(i);
      t.goals[a].push_back(GoalMark{env.race_time_s(e), q.s_ft, q.lateral_ft, q.vertical_ft, p, {b[0], b[1], b[2]}});
    }
  }
}

void RaceRecorder::before_step(const RaceEnv& env) {
  for (int e = 0; e < env.n_env(); ++e) t_before_[e] = env.race_time_s(e);
}

void RaceRecorder::after_step(const RaceEnv& env) {
  const double dt = env.config().dt_ll_s;
  for (int e = 0; e < env.n_env(); ++e) {
    RaceTrace& t = traces_[e];
    if (t.done) continue;
    for (int a = 0; a < env.n_agent(); ++a) {
      const int c = env.step_cause()[e * env.n_agent() + a];
      if (c != kCauseNone) {
        t.cause[a] = c;
        t.out_s[a] = t_before_[e] + dt;
      }
    }
    if (env.env_done()[e]) {
      // The env has already been reset for its next race; the end flags say how this one ended.
      t.done = true;
      t.duration_s = t_before_[e] + dt;
      t.winner = env.race_winner()[e];
      t.end = env.race_end()[e];
      --remaining_;
      continue;
    }
    record_rows(env, e);
  }
}

const char* end_reason_name(int end) {
  switch (end) {
    case RaceEnv::kEndFinishLine: return "finish line";
    case RaceEnv::kEndElimination: return "elimination";
    case RaceEnv::kEndTimeLimit: return "time limit";
    default: return "running";
  }
}

namespace {

const char* kBlues[] = {"#08306b", "#2171b5", "#4292c6", "#6baed6", "#9ecae1", "#0b559f", "#3b7dd8", "#89bde6"};
const char* kReds[] = {"#67000d", "#cb181d", "#ef3b2c", "#fb6a4a", "#fc9272", "#a50f15", "#e34a33", "#fdae91"};

std::string agent_file(const std::string& prefix, int a) { return prefix + "_agent" + std::to_string(a) + ".csv"; }

}  // namespace

void write_trace_csv(const RaceTrace& t, const std::string& dir, const std::string& prefix) {
  const std::vector<std::string> header{"t_s",       "s_ft",         "lateral_ft", "vertical_ft", "pn_ft",
                                        "pe_ft",     "alt_ft",       "vt_ftps",    "phi_rad",     "theta_rad",
                                        "psi_rad",   "radius_ft",    "throttle_cmd", "throttle",  "power_pct",
                                        "alpha_rad"};
  for (std::size_t a = 0; a < t.rows.size(); ++a) {
    std::vector<std::vector<double>> cols(header.size());
    for (const TraceRow& r : t.rows[a]) {
      const double v[] = {r.t_s,        r.s_ft,       r.lateral_ft, r.vertical_ft, r.pn_ft,     r.pe_ft,
                          r.alt_ft,     r.vt_ftps,    r.phi_rad,    r.theta_rad,   r.psi_rad,   r.radius_ft,
                          r.throttle_cmd, r.throttle, r.power_pct,  r.alpha_rad};
      for (std::size_t c = 0; c < header.size(); ++c) cols[c].push_back(v[c]);
    }
    io::write_csv(dir + "/" + agent_file(prefix, static_cast<int>(a)), header, cols);
  }
  // middle_bin on every row: readers of the bins need not know the run's race.hl_bins.
  std::vector<std::vector<double>> g(13);
  for (std::size_t a = 0; a < t.goals.size(); ++a)
    for (const GoalMark& m : t.goals[a]) {
      const double v[] = {static_cast<double>(a), static_cast<double>(RaceEnv::team_of(static_cast<int>(a), t.team_size)),
                          m.t_s, m.s_ft, m.lateral_ft, m.vertical_ft, m.point.n, m.point.e, m.point.u,
                          static_cast<double>(m.bins[0]), static_cast<double>(m.bins[1]), static_cast<double>(m.bins[2]),
                          static_cast<double>(t.middle_bin)};
      for (int c = 0; c < 13; ++c) g[c].push_back(v[c]);
    }
  io::write_csv(dir + "/" + prefix + "_goals.csv",
                {"agent", "team", "t_s", "s_ft", "lateral_ft", "vertical_ft", "pn_ft", "pe_ft", "alt_ft", "bin_x", "bin_y",
                 "bin_z", "middle_bin"},
                g);
  t.track.save_csv(dir + "/" + prefix + "_track.csv");
  // Tube boundary: +-radius every 200 ft along the part of the track the race covered.
  double s_max = 0.0;
  for (const auto& rows : t.rows)
    for (const TraceRow& r : rows) s_max = std::max(s_max, r.s_ft);
  for (const auto& goals : t.goals)
    for (const GoalMark& m : goals) s_max = std::max(s_max, m.s_ft);
  std::vector<std::vector<double>> tube(3);
  for (double s = 0.0; s <= std::min(s_max + 200.0, t.track.length_ft()); s += 200.0) {
    const double r = t.track.radius_at(s);
    tube[0].push_back(s);
    tube[1].push_back(r);
    tube[2].push_back(-r);
  }
  io::write_csv(dir + "/" + prefix + "_tube.csv", {"s_ft", "plus_radius_ft", "minus_radius_ft"}, tube);
}

void write_blocks_csv(const RaceTrace& t, const std::vector<BlockEvent>& blocks, const std::string& dir,
                      const std::string& prefix) {
  // The recorded row nearest in time to the window's opening.
  const auto at = [&](int agent, double t_s) -> const TraceRow* {
    const TraceRow* best = nullptr;
    for (const TraceRow& r : t.rows[agent])
      if (!best || std::fabs(r.t_s - t_s) < std::fabs(best->t_s - t_s)) best = &r;
    return best;
  };
  std::vector<std::vector<double>> c(12);
  for (const BlockEvent& b : blocks) {
    const TraceRow* rb = at(b.blocker, b.t_open_s);
    const TraceRow* ro = at(b.blocked, b.t_open_s);
    if (!rb || !ro) continue;
    const double v[] = {static_cast<double>(b.blocker), static_cast<double>(b.blocked),
                        static_cast<double>(RaceEnv::team_of(b.blocker, t.team_size)), b.t_open_s, b.t_s,
                        b.taken_out ? 1.0 : 0.0, rb->s_ft, rb->lateral_ft, rb->vertical_ft, ro->s_ft, ro->lateral_ft,
                        ro->vertical_ft};
    for (int k = 0; k < 12; ++k) c[k].push_back(v[k]);
  }
  io::write_csv(dir + "/" + prefix + "_blocks.csv",
                {"blocker", "blocked", "blocker_team", "t_open_s", "t_s", "taken_out", "blocker_s_ft",
                 "blocker_lateral_ft", "blocker_vertical_ft", "blocked_s_ft", "blocked_lateral_ft", "blocked_vertical_ft"},
                c);
}

bool plot_trace(const RaceTrace& t, const std::string& dir, const std::string& prefix, const std::string& title,
                std::string* message, const std::vector<BlockEvent>& blocks) {
  io::PlotPanel lat{"Lateral offset in the tube", "forward displacement along the track [ft]", "lateral [ft] (+ right)", {}, ""};
  io::PlotPanel ver{"Vertical offset in the tube", "forward displacement along the track [ft]", "vertical [ft] (+ up)", {}, ""};
  const std::string tube = prefix + "_tube.csv", goals = prefix + "_goals.csv";
  for (io::PlotPanel* p : {&lat, &ver}) {
    p->series.push_back({tube, "1:2", "lines lw 2 lc rgb '#e6b800'", "tube boundary", ""});
    p->series.push_back({tube, "1:3", "lines lw 2 lc rgb '#e6b800'", "", ""});
  }
  bool any_goal = false;
  for (const auto& g : t.goals) any_goal = any_goal || !g.empty();
  for (std::size_t a = 0; a < t.rows.size(); ++a) {
    const int team = RaceEnv::team_of(static_cast<int>(a), t.team_size);
    const std::string color = team == 0 ? kBlues[a % 8] : kReds[a % 8];
    std::string label = std::string(team == 0 ? "blue " : "red ") + std::to_string(a);
    if (t.cause[a] != kCauseNone) label += " (out: " + std::string(cause_name(t.cause[a])) + ")";
    lat.series.push_back({agent_file(prefix, static_cast<int>(a)), "2:3", "lines lw 1.5 lc rgb '" + color + "'", label, ""});
    ver.series.push_back({agent_file(prefix, static_cast<int>(a)), "2:4", "lines lw 1.5 lc rgb '" + color + "'", "", ""});
  }
  if (any_goal) {
    // Goals as open markers in the team colour: team column 2 selects the series.
    for (int team = 0; team < 2; ++team) {
      const std::string sel = "($2==" + std::to_string(team) + "?$4:1/0)";
      const std::string style = std::string("points pt 6 ps 1.2 lc rgb '") + (team == 0 ? "#2171b5" : "#cb181d") + "'";
      const std::string name = team == 0 ? "blue HL goals" : "red HL goals";
      lat.series.push_back({goals, sel + ":5", style, name, ""});
      ver.series.push_back({goals, sel + ":6", style, "", ""});
    }
  }
  if (!blocks.empty()) {
    const std::string file = prefix + "_blocks.csv";
    for (int team = 0; team < 2; ++team) {
      const std::string sel = "($3==" + std::to_string(team) + "?$7:1/0)";
      const std::string style = std::string("points pt 5 ps 1.6 lc rgb '") + (team == 0 ? "#08306b" : "#67000d") + "'";
      const std::string name = team == 0 ? "blue blocks (blocker)" : "red blocks (blocker)";
      lat.series.push_back({file, sel + ":8", style, name, ""});
      ver.series.push_back({file, sel + ":9", style, "", ""});
    }
    lat.series.push_back({file, "10:11", "points pt 2 ps 1.6 lw 2 lc rgb '#000000'", "held up (blocked)", ""});
    ver.series.push_back({file, "10:12", "points pt 2 ps 1.6 lw 2 lc rgb '#000000'", "", ""});
  }
  // Same right margin in both panels (room for the legend), so their x axes line up.
  lat.extra = ver.extra = "set rmargin 34";
  io::PlotSpec spec;
  spec.output = dir + "/" + prefix + ".png";
  spec.rows = 2;
  spec.title = title;
  spec.panels = {lat, ver};
  return io::render_plot(spec, dir + "/" + prefix + ".gp", message);
}

void write_trace_acmi(const RaceTrace& t, const std::string& path, const std::string& title,
                      const std::vector<std::string>& team_names) {
  io::AcmiScene scene;
  scene.title = title;
  const int n_agent = static_cast<int>(t.rows.size());
  for (int a = 0; a < n_agent; ++a) {
    const int team = RaceEnv::team_of(a, t.team_size);
    const std::string side = team == 0 ? "Blue" : "Red";
    const std::string team_name = team < static_cast<int>(team_names.size()) ? team_names[team] : side;
    io::AcmiObject plane;
    plane.id = 0x100 + a;
    plane.type = "Air+FixedWing";
    plane.name = "F-16C";
    plane.pilot = (team == 0 ? "blue " : "red ") + std::to_string(a);
    plane.color = side;
    plane.coalition = team_name;
    for (const TraceRow& r : t.rows[a])
      plane.samples.push_back({r.t_s, r.pn_ft, r.pe_ft, r.alt_ft, r.phi_rad, r.theta_rad, r.psi_rad});
    if (t.out_s[a] >= 0.0) {
      plane.removed_at_s = t.out_s[a];
      plane.destroyed = t.cause[a] == kCauseCollision || t.cause[a] == kCauseAltitude;
    }
    scene.objects.push_back(plane);
    if (!t.goals[a].empty()) {
      io::AcmiObject goal;
      goal.id = 0x200 + a;
      goal.type = "Navaid+Static+Waypoint";
      goal.name = "HL goal " + plane.pilot;
      goal.color = side;
      goal.coalition = team_name;
      goal.attitude = false;
      for (const GoalMark& m : t.goals[a]) goal.samples.push_back({m.t_s, m.point.n, m.point.e, m.point.u});
      if (t.out_s[a] >= 0.0) goal.removed_at_s = t.out_s[a];
      scene.objects.push_back(goal);
    }
  }
  // The center-line every 2 000 ft, and the finish.
  std::uint64_t id = 0x1000;
  for (double s = 0.0; s < t.track.length_ft() + 1.0; s += 2000.0) {
    const double sc = std::min(s, t.track.length_ft());
    const Vec3 p = t.track.point_at(sc);
    io::AcmiObject m;
    m.id = id++;
    m.type = "Navaid+Static+Waypoint";
    m.name = sc >= t.track.length_ft() ? "finish" : "track " + std::to_string(static_cast<int>(sc)) + " ft";
    m.color = "Yellow";
    m.attitude = false;
    m.samples.push_back({0.0, p.n, p.e, p.u});
    scene.objects.push_back(m);
    if (sc >= t.track.length_ft()) break;
  }
  io::write_acmi(path, scene);
}

}  // namespace f16race::race
