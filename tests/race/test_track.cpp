// Track geometry against closed-form cases, generation constraints, determinism, save/load.
#include <gtest/gtest.h>

#include <cmath>
#include <cstdio>
#include <filesystem>

#include "race/track.hpp"

namespace f16race::race {
namespace {

constexpr double kPi = 3.141592653589793;

Track straight_north() {
  // Collinear, evenly spaced waypoints: the spline is the straight line itself.
  return Track::from_waypoints({{{0, 0, 5000}, 1000}, {{1000, 0, 5000}, 1200}, {{2000, 0, 5000}, 1400}, {{3000, 0, 5000}, 1600}},
                               10.0);
}

TEST(Track, StraightLineArcLengthAndProjectionAreExact) {
  const Track t = straight_north();
  EXPECT_NEAR(t.length_ft(), 3000.0, 1e-6);
  // 200 ft east (right of a northbound track) and 100 ft up, 1500 ft along.
  const TrackQuery q = t.project({1500.0, 200.0, 5100.0}, -1);
  EXPECT_NEAR(q.s_ft, 1500.0, 1e-6);
  EXPECT_NEAR(q.lateral_ft, 200.0, 1e-6);
  EXPECT_NEAR(q.vertical_ft, 100.0, 1e-6);
  EXPECT_NEAR(q.dist_ft, std::sqrt(200.0 * 200.0 + 100.0 * 100.0), 1e-6);
  // Radius is linear in arc length between waypoints: halfway between 1200 and 1400.
  EXPECT_NEAR(q.radius_ft, 1300.0, 1e-6);
  EXPECT_NEAR(t.radius_at(2500.0), 1500.0, 1e-6);
  const TrackFrame f = t.frame_at(700.0);
  EXPECT_NEAR(f.tangent.n, 1.0, 1e-12);
  EXPECT_NEAR(f.right.e, 1.0, 1e-12);
  EXPECT_NEAR(f.up.u, 1.0, 1e-12);
}

TEST(Track, CircularArcHasTheArcLengthOfACircle) {
  // Waypoints on a quarter circle of radius R: the centripetal spline stays within a few feet
  // of the circle (away from the end legs, which the phantom end points straighten) and its
  // length is close to pi R / 2.
  const double R = 20000.0;
  std::vector<Waypoint> w;
  for (int k = 0; k <= 9; ++k) {
    const double a = k * (kPi / 2) / 9;
    w.push_back({{R * std::sin(a), R - R * std::cos(a), 8000.0}, 1000.0});
  }
  const Track t = Track::from_waypoints(w, 10.0);
  EXPECT_NEAR(t.length_ft(), kPi * R / 2, 0.001 * kPi * R / 2);
  for (double s = 4000.0; s < t.length_ft() - 4000.0; s += 997.0) {
    const Vec3 p = t.point_at(s);
    const double r = std::sqrt(p.n * p.n + (p.e - R) * (p.e - R));
    EXPECT_NEAR(r, R, 10.0) << "at s=" << s;
  }
  // A point 300 ft outside the circle projects with lateral offset -300 (the turn is to the
  // right, so outside is left).
  const double a = 0.4;
  const TrackQuery q = t.project({(R + 300) * std::sin(a), R - (R + 300) * std::cos(a), 8000.0}, -1);
  EXPECT_NEAR(q.lateral_ft, -300.0, 5.0);
  EXPECT_NEAR(q.s_ft, a * R, 20.0);
}

TEST(Track, WarmStartedProjectionEqualsGlobalSearch) {
  RandomStream rng(7, 0);
  const Track t = Track::generate(TrackConfig{}, rng);
  int hint = -1;
  for (double s = 0.0; s < t.length_ft(); s += 60.0) {
    const TrackFrame f = t.frame_at(s);
    const Vec3 p = f.center + (400.0 * std::sin(s / 3000.0)) * f.right + 250.0 * f.up;
    const TrackQuery warm = t.project(p, hint);
    const TrackQuery cold = t.project(p, -1);
    ASSERT_NEAR(warm.s_ft, cold.s_ft, 1e-9) << "s=" << s;
    ASSERT_NEAR(warm.s_ft, s, 25.0);
    hint = warm.index;
  }
}

TEST(Track, PreviewFollowsTheCenterLineForEveryAircraftAndPoint) {
  // The preview (cubic on a ~500 ft table) against sample(), for aircraft off the center-line,
  // over whole generated tracks including both clamped ends. The points agree to ~2 ft at worst
  // (where the spline's curvature jumps at a waypoint) and a fraction of a foot on average; the
  // radius, linear between waypoints, is rounded off over one table step around each waypoint.
  double worst_point = 0.0, worst_radius = 0.0, sum_point = 0.0;
  int count = 0;
  for (std::uint64_t seed = 0; seed < 8; ++seed) {
    RandomStream rng(seed, 9);
    const Track t = Track::generate(TrackConfig{}, rng);
    constexpr int kAgents = 5, kPoints = 7;
    double progress[kAgents], pn[kAgents], pe[kAgents], pu[kAgents];
    float dn[kAgents * kPoints], de[kAgents * kPoints], du[kAgents * kPoints], radius[kAgents * kPoints];
    for (double s0 = -3000.0; s0 < t.length_ft() + 3000.0; s0 += 123.4) {
      for (int a = 0; a < kAgents; ++a) {
        progress[a] = s0 + 371.0 * a;
        const Vec3 c = t.point_at(progress[a]);
        pn[a] = c.n + 300.0 * a;
        pe[a] = c.e - 200.0;
        pu[a] = c.u + 150.0;
      }
      t.preview(kAgents, kPoints, 1500.0, progress, pn, pe, pu, dn, de, du, radius);
      for (int a = 0; a < kAgents; ++a) {
        for (int p = 0; p < kPoints; ++p) {
          const int k = a * kPoints + p;
          double r_ref;
          const Vec3 q = t.sample(progress[a] + (p + 1) * 1500.0, &r_ref);
          const double err = std::sqrt(std::pow(dn[k] - (q.n - pn[a]), 2) + std::pow(de[k] - (q.e - pe[a]), 2) +
                                       std::pow(du[k] - (q.u - pu[a]), 2));
          worst_point = std::max(worst_point, err);
          sum_point += err;
          ++count;
          worst_radius = std::max(worst_radius, std::fabs(radius[k] - r_ref));
          ASSERT_LT(err, 2.5) << "seed " << seed << " s " << progress[a] << " p " << p;
          ASSERT_LT(std::fabs(radius[k] - r_ref), 25.0) << "seed " << seed << " s " << progress[a] << " p " << p;
        }
      }
    }
  }
  EXPECT_LT(sum_point / count, 0.15);
  std::printf("preview vs sample(): point error mean %.3f ft, worst %.3f ft; worst radius error %.2f ft\n",
              sum_point / count, worst_point, worst_radius);
}

TEST(Track, ProjectionOnACurveIsTheClosestCenterLinePoint) {
  // Brute force over a fine resampling of the center-line: the projected point is the closest
  // one to well within a sample spacing, and the offsets reproduce the distance.
  RandomStream rng(3, 1);
  const Track t = Track::generate(TrackConfig{}, rng);
  for (double s = 500.0; s < t.length_ft() - 500.0; s += 777.0) {
    const TrackFrame f = t.frame_at(s);
    const Vec3 p = f.center + 600.0 * f.right - 350.0 * f.up;
    const TrackQuery q = t.project(p, -1);
    double best = 1e300, best_s = 0.0;
    for (double u = s - 1000.0; u <= s + 1000.0; u += 1.0) {
      const Vec3 d = p - t.point_at(u);
      if (dot(d, d) < best) best = dot(d, d), best_s = u;
    }
    EXPECT_NEAR(q.s_ft, best_s, 2.0) << "s=" << s;
    EXPECT_NEAR(q.dist_ft, std::sqrt(best), 0.5) << "s=" << s;
    EXPECT_NEAR(q.lateral_ft, 600.0, 2.0);
    EXPECT_NEAR(q.vertical_ft, -350.0, 2.0);
  }
}

TEST(Track, GenerationRespectsItsConstraintsAndIsDeterministic) {
  const TrackConfig c;
  for (std::uint64_t seed = 0; seed < 40; ++seed) {
    RandomStream a(seed, 3), b(seed, 3);
    const Track t1 = Track::generate(c, a), t2 = Track::generate(c, b);
    ASSERT_EQ(t1.waypoints().size(), static_cast<std::size_t>(c.n_waypoints));
    ASSERT_LE(t1.n_samples(), Track::max_samples(c));  // the env's reserved capacity suffices
    double h0 = 0.0, prev_h = 0.0;
    for (std::size_t k = 0; k < t1.waypoints().size(); ++k) {
      const Waypoint& w = t1.waypoints()[k];
      EXPECT_EQ(w.p.n, t2.waypoints()[k].p.n);  // bit-identical for the same stream
      EXPECT_GE(w.p.u, c.alt_min_ft);
      EXPECT_LE(w.p.u, c.alt_max_ft);
      EXPECT_GE(w.radius_ft, c.radius_min_ft);
      EXPECT_LE(w.radius_ft, c.radius_max_ft);
      if (k == 0) continue;
      const Vec3 d = w.p - t1.waypoints()[k - 1].p;
      const double h = std::atan2(d.e, d.n);
      const double horiz = std::sqrt(d.n * d.n + d.e * d.e);
      EXPECT_LE(std::fabs(std::atan2(d.u, horiz)) * 180 / kPi, c.max_climb_deg + 1e-9);
      if (k == 1) {
        h0 = h;
      } else {
        EXPECT_LE(std::fabs(std::remainder(h - prev_h, 2 * kPi)) * 180 / kPi, c.max_turn_deg + 1e-9);
      }
      EXPECT_LE(std::fabs(std::remainder(h - h0, 2 * kPi)) * 180 / kPi, c.max_heading_dev_deg + 1e-9);
      prev_h = h;
    }
  }
  RandomStream x(1, 0), y(2, 0);
  EXPECT_NE(Track::generate(c, x).waypoints()[3].p.n, Track::generate(c, y).waypoints()[3].p.n);
}

TEST(Track, SaveLoadRoundTripIsExact) {
  RandomStream rng(11, 5);
  const Track t = Track::generate(TrackConfig{}, rng);
  const std::string path = (std::filesystem::temp_directory_path() / "f16race_track_test.csv").string();
  t.save_csv(path);
  const Track u = Track::load_csv(path);
  ASSERT_EQ(u.waypoints().size(), t.waypoints().size());
  for (std::size_t k = 0; k < t.waypoints().size(); ++k) {
    EXPECT_EQ(u.waypoints()[k].p.e, t.waypoints()[k].p.e);
    EXPECT_EQ(u.waypoints()[k].radius_ft, t.waypoints()[k].radius_ft);
  }
  EXPECT_EQ(u.length_ft(), t.length_ft());
  std::remove(path.c_str());
}

TEST(Track, BadWaypointsAreRefused) {
  EXPECT_THROW(Track::from_waypoints({{{0, 0, 0}, 100}, {{1, 0, 0}, 100}}), std::invalid_argument);
  EXPECT_THROW(Track::from_waypoints({{{0, 0, 0}, 100}, {{1000, 0, 0}, -5}, {{2000, 0, 0}, 100}, {{3000, 0, 0}, 100}}),
               std::invalid_argument);
}

}  // namespace
}  // namespace f16race::race
