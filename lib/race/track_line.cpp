#include "race/track_line.hpp"

#include <algorithm>
#include <cmath>
#include <vector>

namespace f16race::race {

namespace {

// The point of cross-section f (its disc of radius r) nearest to `target`: the target projected
// onto the section's plane, then pulled inside the disc.
Vec3 nearest_in_section(const TrackFrame& f, double r, Vec3 target) {
  const Vec3 d = target - f.center;
  double y = dot(d, f.right), z = dot(d, f.up);
  const double len = std::hypot(y, z);
  if (len > r) y *= r / len, z *= r / len;
  return f.center + y * f.right + z * f.up;
}

double polyline_ft(const std::vector<Vec3>& p) {
  double sum = 0.0;
  for (std::size_t k = 1; k < p.size(); ++k) sum += norm(p[k] - p[k - 1]);
  return sum;
}

// The cross-sections of a stretch, n of them evenly spaced, and their radii (inset applied).
struct Sections {
  std::vector<TrackFrame> frames;
  std::vector<double> radius;
};

Sections sections(const Track& track, const TubeLineInputs& in, int n) {
  Sections s{std::vector<TrackFrame>(n), std::vector<double>(n)};
  for (int k = 0; k < n; ++k) {
    s.frames[k] = track.frame_at(in.s0_ft + (in.s1_ft - in.s0_ft) * k / (n - 1));
    s.radius[k] = (1.0 - in.inset_frac) * s.frames[k].radius_ft;
  }
  return s;
}

// Gauss-Seidel relaxation of a string: each point moves to the point of its cross-section nearest
// to the midpoint of its neighbours (the two ends to their one neighbour: the start and the
// finish are whole cross-sections, not points). Each move shortens the string, so it converges
// to the taut line. Returns the sweeps it took.
int relax(const Sections& s, std::vector<Vec3>* points, int max_sweeps, double tolerance_ft) {
  std::vector<Vec3>& p = *points;
  const int n = static_cast<int>(p.size());
  int sweeps = 0;
  while (sweeps < max_sweeps) {
    ++sweeps;
    double moved = 0.0;
    for (int k = 0; k < n; ++k) {
      const Vec3 target = k == 0 ? p[1] : k == n - 1 ? p[n - 2] : 0.5 * (p[k - 1] + p[k + 1]);
      const Vec3 q = nearest_in_section(s.frames[k], s.radius[k], target);
      moved = std::max(moved, norm(q - p[k]));
      p[k] = q;
    }
    if (moved < tolerance_ft) break;
  }
  return sweeps;
}

}  // namespace

// Straight free stretches relax slowest (their error halves only every ~n^2 / 4 sweeps), so the
// string is first relaxed on sections 16, 8, 4 and 2 times as far apart, each level started
// from the one before (its offsets in the sections, interpolated along the track).
TubeLine shortest_tube_line(const Track& track, const TubeLineInputs& in) {
  const int n = std::max(2, static_cast<int>(std::ceil((in.s1_ft - in.s0_ft) / in.step_ft)) + 1);
  TubeLine out;
  out.s0_ft = in.s0_ft, out.s1_ft = in.s1_ft;
  std::vector<double>& lat = out.right_ft;  // the previous level's offsets until the last level's
  std::vector<double>& vert = out.up_ft;
  for (int coarsen = 16; coarsen >= 1; coarsen /= 2) {
    const int m = coarsen == 1 ? n : (n - 1) / coarsen + 1;
    if (m < 3 && coarsen > 1) continue;
    const Sections s = sections(track, in, m);
    std::vector<Vec3> p(m);
    for (int k = 0; k < m; ++k) {
      const TubeLine::Offset o = out.offset_at(in.s0_ft + (in.s1_ft - in.s0_ft) * k / (m - 1));
      const TrackFrame& f = s.frames[k];
      p[k] = nearest_in_section(f, s.radius[k], f.center + o.right_ft * f.right + o.up_ft * f.up);
    }
    if (coarsen == 1) {
      std::vector<Vec3> c(m);
      for (int k = 0; k < m; ++k) c[k] = s.frames[k].center;
      out.center_ft = polyline_ft(c);
    }
    out.sweeps += relax(s, &p, in.max_sweeps - out.sweeps, in.tolerance_ft);
    lat.resize(m), vert.resize(m);
    for (int k = 0; k < m; ++k) {
      lat[k] = dot(p[k] - s.frames[k].center, s.frames[k].right);
      vert[k] = dot(p[k] - s.frames[k].center, s.frames[k].up);
    }
    if (coarsen == 1) out.shortest_ft = polyline_ft(p);
  }
  return out;
}

TubeLine::Offset TubeLine::offset_at(double s_ft) const {
  if (right_ft.size() < 2 || s1_ft <= s0_ft) return right_ft.empty() ? Offset{} : Offset{right_ft[0], up_ft[0]};
  const double x = std::clamp((s_ft - s0_ft) / (s1_ft - s0_ft), 0.0, 1.0) * (right_ft.size() - 1);
  const std::size_t j = std::min(static_cast<std::size_t>(x), right_ft.size() - 2);
  const double w = x - j;
  return {right_ft[j] + w * (right_ft[j + 1] - right_ft[j]), up_ft[j] + w * (up_ft[j + 1] - up_ft[j])};
}

}  // namespace f16race::race
