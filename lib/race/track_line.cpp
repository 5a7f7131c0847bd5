#include "race/track_line.hpp"

#include <cmath>
#include <vector>

namespace f16race::race {

namespace {

double norm(Vec3 a) { return std::sqrt(dot(a, a)); }

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

}  // namespace

// Gauss-Seidel relaxation of a string: each point moves to the point of its cross-section nearest
// to the midpoint of its neighbours (the two ends to their one neighbour: the start and the
// finish are whole cross-sections, not points). Each move shortens the string, so it converges
// to the taut line; straight free stretches converge slowest, hence the sweep budget.
TubeLine shortest_tube_line(const Track& track, const TubeLineInputs& in) {
  const int n = std::max(2, static_cast<int>(std::ceil((in.s1_ft - in.s0_ft) / in.step_ft)) + 1);
  std::vector<TrackFrame> frames(n);
  std::vector<double> radius(n);
  std::vector<Vec3> p(n);
  for (int k = 0; k < n; ++k) {
    frames[k] = track.frame_at(in.s0_ft + (in.s1_ft - in.s0_ft) * k / (n - 1));
    radius[k] = (1.0 - in.inset_frac) * frames[k].radius_ft;
    p[k] = frames[k].center;
  }
  TubeLine out;
  out.center_ft = polyline_ft(p);
  for (out.sweeps = 0; out.sweeps < in.max_sweeps;) {
    ++out.sweeps;
    double moved = 0.0;
    for (int k = 0; k < n; ++k) {
      const Vec3 target = k == 0 ? p[1] : k == n - 1 ? p[n - 2] : 0.5 * (p[k - 1] + p[k + 1]);
      const Vec3 q = nearest_in_section(frames[k], radius[k], target);
      moved = std::max(moved, norm(q - p[k]));
      p[k] = q;
    }
    if (moved < 1e-5) break;
  }
  out.shortest_ft = polyline_ft(p);
  return out;
}

}  // namespace f16race::race
