// The replay page's data (eval/replay_page.hpp) on a hand-built race: sized for a laptop, thinned
// to at most 20 Hz, cut before a non-finite state, and no run name can end its <script> early.
#include <gtest/gtest.h>

#include <cmath>
#include <limits>
#include <string>
#include <vector>

#include "eval/replay_page.hpp"
#include "io/viewer_page.hpp"
#include "race/track_line.hpp"

namespace f16race::eval {
namespace {

// A race of 8 aircraft flying the center-line side by side for `duration_s`, LL step dt_s;
// aircraft 5 out by collision half-way.
RaceReplay straight_race(double duration_s, double dt_s) {
  RaceReplay r;
  r.race.dt_ll_s = dt_s;
  r.race.finish_margin_ft = 1500.0;
  r.blue = "run";
  r.red = "autopilot";
  race::RaceTrace& t = r.trace;
  t.track = race::Track::from_waypoints({{{0, 0, 8000}, 1200}, {{20000, 3000, 8500}, 1500}, {{40000, 0, 9000}, 1000},
                                         {{60000, 4000, 9000}, 1300}});
  t.team_size = 4;
  t.rows.resize(8);
  t.goals.resize(8);
  t.cause.assign(8, race::kCauseNone);
  t.out_s.assign(8, -1.0);
  t.cause[5] = race::kCauseCollision;
  t.out_s[5] = duration_s / 2;
  const int steps = static_cast<int>(std::lround(duration_s / dt_s));
  for (int a = 0; a < 8; ++a) {
    const int n = a == 5 ? steps / 2 : steps;
    for (int k = 0; k < n; ++k) {
      const double s = 1500.0 + 800.0 * k * dt_s;
      const race::Vec3 p = t.track.point_at(s);
      t.rows[a].push_back(
          {k * dt_s, s, 30.0 * a, 0.0, p.n, p.e + 30.0 * a, p.u, 800.0, 0.1, 0.02, 0.3, 1200.0, 0.9, 0.25, 20.0, 0.05});
    }
    for (double g = 0.0; g < duration_s; g += 8.0) t.goals[a].push_back({g, 9000.0, 0.0, 0.0, {9000.0, 0.0, 8500.0}, {3, 3, 4}});
  }
  r.blocks.push_back({0, 1, 6, 10.0, 13.5, true});
  t.duration_s = steps * dt_s;
  t.done = true;
  return r;
}

// The number of entries of the JSON array that follows `key` after position `from`.
int array_size(const std::string& json, const std::string& key, std::size_t from) {
  const std::size_t open = json.find(key + ":[", from) + key.size() + 2, close = json.find(']', open);
  if (close == open) return 0;
  int n = 1;
  for (std::size_t i = open; i < close; ++i) n += json[i] == ',';
  return n;
}

TEST(ReplayPage, SixtySecondsOfEightAircraftFitALaptop) {
  const RaceReplay r = straight_race(60.0, 0.08);
  const std::string json = replay_page_json(r);
  const std::string page = io::viewer_page_html(json);
  EXPECT_LT(json.size(), 600'000u) << "the race's data";
  EXPECT_LT(page.size(), 3'000'000u) << "the whole page, three.js included";
  // The LL step of 0.08 s is kept: 750 frames, every aircraft's columns as long as its life.
  EXPECT_NE(json.find("\"dt_s\":0.0800,\"frames\":750,"), std::string::npos);
  EXPECT_NE(json.find("\"duration_s\":60.00"), std::string::npos);
  const std::size_t a5 = json.find("\"label\":\"red 5\"");
  ASSERT_NE(a5, std::string::npos);
  EXPECT_EQ(array_size(json, "\"n\"", a5), 375);
  EXPECT_EQ(array_size(json, "\"psi\"", a5), 375);
  EXPECT_NE(json.find("\"out_s\":30.00,\"cause\":\"collision\"", a5), std::string::npos);
  const std::size_t goals = json.find("\"goals\":[[0.00,", a5);
  ASSERT_NE(goals, std::string::npos);
  int decisions = 0;
  for (std::size_t i = goals + 9; json.compare(i - 1, 2, "]]") != 0; ++i) decisions += json[i] == '[';
  EXPECT_EQ(decisions, 8);  // every 8 s of 60
  EXPECT_NE(json.find("\"blocks\":[[1,6,10.00,13.50,1]]"), std::string::npos);
  // Angles in centiradians, airspeed in whole ft/s: phi 0.1 rad is 10.
  EXPECT_NE(json.find("\"phi\":[10,10,", a5), std::string::npos);
  EXPECT_NE(json.find("\"vt\":[800,800,", a5), std::string::npos);
  // Mach in thousandths at the row's altitude (AeroBench's adc: speed of sound from 519 R with the
  // 0.703e-5 per ft lapse; ~0.737 at 800 ft/s and 8 000 ft), the throttle flown in percent.
  const double alt_ft = r.trace.rows[5][0].alt_ft;
  const long mach = std::lround(1000.0 * 800.0 / std::sqrt(1.4 * 1716.3 * 519.0 * (1.0 - 0.703e-5 * alt_ft)));
  EXPECT_NE(json.find("\"mach\":[" + std::to_string(mach) + ",", a5), std::string::npos) << json.substr(a5, 200);
  EXPECT_NEAR(mach, 737.5, 1.0);
  EXPECT_NE(json.find("\"thr\":[25,25,", a5), std::string::npos);
  EXPECT_EQ(array_size(json, "\"mach\"", a5), 375);
}

// The racing line (race.goal_line_frac) is drawn from start to finish at the rings' spacing,
// each point the center-line's plus the line's offsets there; without one the key is null.
TEST(ReplayPage, CarriesTheRacingLineWhenTheGoalsWerePlacedAroundOne) {
  RaceReplay r = straight_race(10.0, 0.08);
  EXPECT_NE(replay_page_json(r).find("\"racing_line\":null,"), std::string::npos);
  const double s1 = r.trace.track.length_ft() - 1500.0;
  r.line = race::shortest_tube_line(r.trace.track, {1500.0, s1, 0.75});
  const std::string json = replay_page_json(r);
  const std::size_t at = json.find("\"racing_line\":{\"n\":[");
  ASSERT_NE(at, std::string::npos);
  const int n = array_size(json, "\"n\"", at);
  EXPECT_EQ(n, static_cast<int>(std::ceil((s1 - 1500.0) / 200.0)) + 1);
  EXPECT_EQ(array_size(json, "\"u\"", at), n);
  // Its last point: the finish section's, offset by the line's last offsets (relative to the
  // page's origin, whole feet).
  const race::TrackFrame f = r.trace.track.frame_at(s1);
  const race::Vec3 p = f.center + r.line.right_ft.back() * f.right + r.line.up_ft.back() * f.up;
  const std::size_t u = json.find("\"u\":[", at);
  const std::size_t end = json.find(']', u);
  EXPECT_EQ(json.substr(json.rfind(',', end) + 1, end - json.rfind(',', end) - 1), std::to_string(std::lround(p.u)));
  EXPECT_GT(std::abs(r.line.right_ft[r.line.right_ft.size() / 3]), 10.0);  // a line that leaves the center
}

TEST(ReplayPage, FineStepsAreThinnedToTwentyHertz) {
  const std::string json = replay_page_json(straight_race(30.0, 0.01));
  EXPECT_NE(json.find("\"dt_s\":0.0500,\"frames\":600,"), std::string::npos) << json.substr(0, 300);
  EXPECT_EQ(array_size(json, "\"u\"", json.find("\"label\":\"blue 0\"")), 600);
}

TEST(ReplayPage, StopsAnAircraftBeforeANonFiniteState) {
  RaceReplay r = straight_race(20.0, 0.08);
  r.trace.rows[2][100].theta_rad = std::numeric_limits<double>::quiet_NaN();
  const std::string json = replay_page_json(r);
  EXPECT_EQ(array_size(json, "\"theta\"", json.find("\"label\":\"blue 2\"")), 100);
  EXPECT_EQ(json.find("nan"), std::string::npos);
}

TEST(ReplayPage, NoNameClosesTheDataScript) {
  RaceReplay r = straight_race(10.0, 0.08);
  r.blue = "x</script><script>alert(1)</script>";
  const std::string page = io::viewer_page_html(replay_page_json(r));
  int closes = 0;
  for (std::size_t at = page.find("</script>"); at != std::string::npos; at = page.find("</script>", at + 1)) ++closes;
  EXPECT_EQ(closes, 3);  // the data, three.js and the viewer: nothing else ends a script
  EXPECT_NE(page.find("x\\u003c/script>\\u003cscript>alert(1)"), std::string::npos);
}

}  // namespace
}  // namespace f16race::eval
