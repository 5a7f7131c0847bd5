#include "eval/replay_page.hpp"

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <string>
#include <vector>

#include "dynamics/engine.hpp"
#include "io/json_text.hpp"
#include "io/viewer_page.hpp"

namespace f16race::eval {

namespace {

// Quantised numbers: whole units (feet, ft/s, centiradians) or a fixed number of decimals.
std::string whole(double x) { return std::to_string(std::lround(x)); }

std::string decimals(double x, int digits) {
  char b[48];
  std::snprintf(b, sizeof b, "%.*f", digits, x);
  return b;
}

struct Origin {
  double n = 0.0, e = 0.0;  // the track's center: positions are written relative to it
};

Origin track_center(const race::Track& track) {
  double n0 = 1e300, n1 = -1e300, e0 = 1e300, e1 = -1e300;
  for (const race::Waypoint& w : track.waypoints()) {
    n0 = std::min(n0, w.p.n), n1 = std::max(n1, w.p.n);
    e0 = std::min(e0, w.p.e), e1 = std::max(e1, w.p.e);
  }
  return {std::round(0.5 * (n0 + n1)), std::round(0.5 * (e0 + e1))};
}

// "[a,b,c]" of the values f(i) for i in [0, n).
template <class F>
std::string array(std::size_t n, F f) {
  std::string s = "[";
  for (std::size_t i = 0; i < n; ++i) (s += i ? "," : "") += f(i);
  return s + "]";
}

bool finite_row(const race::TraceRow& r) {
  return std::isfinite(r.pn_ft) && std::isfinite(r.pe_ft) && std::isfinite(r.alt_ft) && std::isfinite(r.vt_ftps) &&
         std::isfinite(r.phi_rad) && std::isfinite(r.theta_rad) && std::isfinite(r.psi_rad) && std::isfinite(r.s_ft);
}

std::string aircraft_json(const RaceReplay& r, int a, int stride, const Origin& o) {
  const race::RaceTrace& t = r.trace;
  // Every stride-th row, up to the first non-finite one (a simulator failure takes the aircraft
  // out at the next step; JSON has no NaN, and the page draws what came before).
  std::vector<const race::TraceRow*> rows;
  for (std::size_t k = 0; k < t.rows[a].size() && finite_row(t.rows[a][k]); k += stride) rows.push_back(&t.rows[a][k]);
  const auto col = [&](auto field) { return array(rows.size(), [&](std::size_t i) { return whole(field(*rows[i])); }); };
  const int team = race::RaceEnv::team_of(a, t.team_size);
  std::string s = "{\"label\":" + io::json_string((team == 0 ? "blue " : "red ") + std::to_string(a)) +
                  ",\"team\":" + std::to_string(team);
  s += ",\"n\":" + col([&](const race::TraceRow& x) { return x.pn_ft - o.n; });
  s += ",\"e\":" + col([&](const race::TraceRow& x) { return x.pe_ft - o.e; });
  s += ",\"u\":" + col([](const race::TraceRow& x) { return x.alt_ft; });
  s += ",\"phi\":" + col([](const race::TraceRow& x) { return 100.0 * x.phi_rad; });
  s += ",\"theta\":" + col([](const race::TraceRow& x) { return 100.0 * x.theta_rad; });
  s += ",\"psi\":" + col([](const race::TraceRow& x) { return 100.0 * x.psi_rad; });
  s += ",\"vt\":" + col([](const race::TraceRow& x) { return x.vt_ftps; });
  // Mach in thousandths (the envelope caps it at race.mach_max) and the throttle flown in percent:
  // at the cap, what separates two pilots.
  s += ",\"mach\":" + col([](const race::TraceRow& x) { return 1000.0 * dynamics::air_data(x.vt_ftps, x.alt_ft).mach; });
  s += ",\"thr\":" + col([](const race::TraceRow& x) { return 100.0 * x.throttle; });
  s += ",\"s\":" + col([](const race::TraceRow& x) { return x.s_ft; });
  const bool out = t.cause[a] != race::kCauseNone;
  s += ",\"out_s\":" + (out ? decimals(t.out_s[a], 2) : std::string("-1"));
  s += ",\"cause\":" + io::json_string(out ? race::cause_name(t.cause[a]) : "");
  const std::vector<race::GoalMark>& g = t.goals[a];
  s += ",\"goals\":" + array(g.size(), [&](std::size_t i) {
         const race::GoalMark& m = g[i];
         return "[" + decimals(m.t_s, 2) + "," + whole(m.point.n - o.n) + "," + whole(m.point.e - o.e) + "," +
                whole(m.point.u) + "," + std::to_string(m.bins[0]) + "," + std::to_string(m.bins[1]) + "," +
                std::to_string(m.bins[2]) + "]";
       });
  return s + "}";
}

// ft: the tube's rings and the lines' points; ~20 ft off the spline at most on these turns.
constexpr double kSampleSpacingFt = 200.0;

// "n":[...],"e":[...],"u":[...] of points, n and e relative to the page's origin, whole feet.
std::string points_json(const std::vector<race::Vec3>& p, const Origin& o) {
  const std::size_t n = p.size();
  return "\"n\":" + array(n, [&](std::size_t i) { return whole(p[i].n - o.n); }) +
         ",\"e\":" + array(n, [&](std::size_t i) { return whole(p[i].e - o.e); }) +
         ",\"u\":" + array(n, [&](std::size_t i) { return whole(p[i].u); });
}

std::string track_json(const RaceReplay& r, const Origin& o) {
  const race::Track& tr = r.trace.track;
  const std::size_t n = static_cast<std::size_t>(std::ceil(tr.length_ft() / kSampleSpacingFt)) + 1;
  std::vector<race::Vec3> p(n);
  std::vector<double> radius(n);
  for (std::size_t i = 0; i < n; ++i) {
    const double s = std::min(tr.length_ft(), static_cast<double>(i) * kSampleSpacingFt);
    p[i] = tr.point_at(s);
    radius[i] = tr.radius_at(s);
  }
  return "{\"length_ft\":" + decimals(tr.length_ft(), 1) +
         ",\"finish_s_ft\":" + decimals(tr.length_ft() - r.race.finish_margin_ft, 1) +
         ",\"spacing_ft\":" + whole(kSampleSpacingFt) + "," + points_json(p, o) +
         ",\"r\":" + array(n, [&](std::size_t i) { return whole(radius[i]); }) + "}";
}

// The racing line the goals were placed around (race.goal_line_frac), start to finish, at the
// tube rings' spacing; "null" when the goals were around the center-line.
std::string line_json(const RaceReplay& r, const Origin& o) {
  const race::TubeLine& line = r.line;
  if (line.right_ft.empty()) return "null";
  const std::size_t n = static_cast<std::size_t>(std::ceil((line.s1_ft - line.s0_ft) / kSampleSpacingFt)) + 1;
  std::vector<race::Vec3> p(n);
  for (std::size_t i = 0; i < n; ++i) {
    const double s = std::min(line.s1_ft, line.s0_ft + static_cast<double>(i) * kSampleSpacingFt);
    const race::TrackFrame f = r.trace.track.frame_at(s);
    const race::TubeLine::Offset w = line.offset_at(s);
    p[i] = f.center + w.right_ft * f.right + w.up_ft * f.up;
  }
  return "{" + points_json(p, o) + "}";
}

}  // namespace

std::string replay_page_json(const RaceReplay& r) {
  const race::RaceTrace& t = r.trace;
  const double dt = r.race.dt_ll_s;
  const int stride = std::max(1, static_cast<int>(std::ceil(kPageMinSampleS / dt - 1e-9)));
  std::size_t steps = 0;
  for (const auto& rows : t.rows) steps = std::max(steps, rows.size());
  const std::size_t frames = std::max<std::size_t>(1, (steps + stride - 1) / stride);
  const Origin o = track_center(t.track);
  const std::string blue = "Blue: " + r.blue, red = "Red: " + r.red;
  const std::string winner = t.winner < 0 ? "draw" : (t.winner == 0 ? "blue" : "red");
  std::string s = "{\"format\":1,\"title\":" + io::json_string(blue + " vs " + red);
  s += ",\"teams\":[" + io::json_string(blue) + "," + io::json_string(red) + "]";
  s += ",\"team_size\":" + std::to_string(t.team_size);
  s += ",\"dt_s\":" + decimals(dt * stride, 4) + ",\"frames\":" + std::to_string(frames);
  s += ",\"duration_s\":" + decimals(t.duration_s, 2);
  s += ",\"end\":" + io::json_string(race::end_reason_name(t.end)) + ",\"winner\":" + io::json_string(winner);
  s += ",\"goal_frame\":" + io::json_string(r.race.goal_frame == race::GoalFrame::kTrack ? "track" : "world");
  s += ",\"origin_ft\":[" + whole(o.n) + "," + whole(o.e) + ",0]";
  s += ",\"track\":" + track_json(r, o);
  s += ",\"racing_line\":" + line_json(r, o);
  s += ",\"aircraft\":" + array(t.rows.size(), [&](std::size_t a) { return aircraft_json(r, static_cast<int>(a), stride, o); });
  s += ",\"blocks\":" + array(r.blocks.size(), [&](std::size_t i) {
         const race::BlockEvent& b = r.blocks[i];
         return "[" + std::to_string(b.blocker) + "," + std::to_string(b.blocked) + "," + decimals(b.t_open_s, 2) + "," +
                decimals(b.t_s, 2) + "," + (b.taken_out ? "1" : "0") + "]";
       });
  return s + "}";
}

void write_replay_page(const RaceReplay& replay, const std::string& path) {
  io::write_viewer_page(path, replay_page_json(replay));
}

}  // namespace f16race::eval
