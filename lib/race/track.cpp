#include "race/track.hpp"

#include <algorithm>
#include <cmath>
#include <stdexcept>
#include <string>

#include "dynamics/physical_constants.hpp"
#include "io/csv_table.hpp"

namespace f16race::race {
namespace {

using dynamics::kDegToRad;
using dynamics::kPi;

Vec3 normalized(Vec3 a) {
  const double n = norm(a);
  return n > 0.0 ? (1.0 / n) * a : Vec3{1.0, 0.0, 0.0};
}
Vec3 cross(Vec3 a, Vec3 b) { return {a.e * b.u - a.u * b.e, a.u * b.n - a.n * b.u, a.n * b.e - a.e * b.n}; }

// Centripetal Catmull-Rom (Barry-Goldman form) between p1 and p2: no cusps or self-loops
// within a segment even for uneven waypoint spacing.
// Centripetal Catmull-Rom segment from p1 to p2. The knots depend only on the four points, so
// they are computed once per segment, not per evaluation (track generation runs at every race
// reset); the arithmetic per evaluation is unchanged.
struct CatmullRomSegment {
  Vec3 p0, p1, p2, p3;
  double t0, t1, t2, t3;
  CatmullRomSegment(Vec3 a, Vec3 b, Vec3 c, Vec3 d) : p0(a), p1(b), p2(c), p3(d) {
    auto knot = [](double t, Vec3 x, Vec3 y) { return t + std::sqrt(std::max(norm(y - x), 1e-9)); };
    t0 = 0.0;
    t1 = knot(t0, p0, p1);
    t2 = knot(t1, p1, p2);
    t3 = knot(t2, p2, p3);
  }
  Vec3 at(double u) const {
    const double t = t1 + u * (t2 - t1);
    auto lerp = [](Vec3 a, Vec3 b, double ta, double tb, double tt) {
      return ((tb - tt) / (tb - ta)) * a + ((tt - ta) / (tb - ta)) * b;
    };
    const Vec3 a1 = lerp(p0, p1, t0, t1, t), a2 = lerp(p1, p2, t1, t2, t), a3 = lerp(p2, p3, t2, t3, t);
    const Vec3 b1 = lerp(a1, a2, t0, t2, t), b2 = lerp(a2, a3, t1, t3, t);
    return lerp(b1, b2, t1, t2, t);
  }
};

}  // namespace

Track Track::generate(const TrackConfig& c, RandomStream& rng) {
  std::vector<Waypoint> wps;
  const double margin = 0.25 * (c.alt_max_ft - c.alt_min_ft);
  Vec3 p{0.0, 0.0, rng.uniform(c.alt_min_ft + margin, c.alt_max_ft - margin)};
  const double heading0 = rng.uniform(0.0, 2.0 * kPi);
  double heading = heading0;
  double climb = 0.0;  // the first leg is level: the race starts from level trimmed flight
  wps.push_back({p, rng.uniform(c.radius_min_ft, c.radius_max_ft)});
  for (int k = 1; k < c.n_waypoints; ++k) {
    if (k > 1) {
      heading += rng.uniform(-c.max_turn_deg, c.max_turn_deg) * kDegToRad;
      // Reflect at the deviation bound: every leg keeps moving along the first leg's direction,
      // so the center-line never crosses itself and progress is unambiguous.
      const double dev = heading - heading0, lim = c.max_heading_dev_deg * kDegToRad;
      if (dev > lim) heading = heading0 + 2.0 * lim - dev;
      if (dev < -lim) heading = heading0 - 2.0 * lim - dev;
      climb += rng.uniform(-c.max_climb_change_deg, c.max_climb_change_deg) * kDegToRad;
      climb = std::clamp(climb, -c.max_climb_deg * kDegToRad, c.max_climb_deg * kDegToRad);
    }
    const double leg = rng.uniform(c.leg_min_ft, c.leg_max_ft);
    Vec3 next = p + leg * Vec3{std::cos(climb) * std::cos(heading), std::cos(climb) * std::sin(heading), std::sin(climb)};
    if (next.u < c.alt_min_ft || next.u > c.alt_max_ft) {  // bounce off the altitude band
      climb = -climb;
      next = p + leg * Vec3{std::cos(climb) * std::cos(heading), std::cos(climb) * std::sin(heading), std::sin(climb)};
      next.u = std::clamp(next.u, c.alt_min_ft, c.alt_max_ft);
    }
    p = next;
    wps.push_back({p, rng.uniform(c.radius_min_ft, c.radius_max_ft)});
  }
  return from_waypoints(std::move(wps), c.spacing_ft);
}

namespace {
// Entries of the preview table of a track with `n_samples` samples (see preview_table_).
int preview_entries(int n_samples, int stride) { return (n_samples - 1) / stride + 4; }
}  // namespace

Track::Track(std::pmr::memory_resource* memory, const TrackConfig& config)
    : samples_(memory), tangents_(memory), frames_(memory), preview_table_(memory) {
  const int m = max_samples(config);
  samples_.reserve(m);
  tangents_.reserve(m);
  frames_.reserve(m);
  preview_table_.reserve(4 * preview_entries(m, preview_stride(config.spacing_ft)));
}

int Track::preview_stride(double spacing_ft) {
  // ~500 ft: the cubic stays within ~0.1 ft of the center-line on average (~2 ft where the
  // curvature jumps at a waypoint), and one cache line holds 2 000 ft of track.
  return std::max(1, static_cast<int>(std::lround(500.0 / spacing_ft)));
}

int Track::max_samples(const TrackConfig& c) {
  return static_cast<int>(std::ceil(1.5 * (c.n_waypoints - 1) * c.leg_max_ft / c.spacing_ft)) + 2;
}

std::size_t Track::storage_bytes(const TrackConfig& config) {
  const int m = max_samples(config);
  const std::size_t n = static_cast<std::size_t>(m);
  const std::size_t table = 4 * sizeof(float) * static_cast<std::size_t>(preview_entries(m, preview_stride(config.spacing_ft)));
  return n * (sizeof(Sample) + sizeof(Vec3) + sizeof(SegmentFrame)) + table + 4 * alignof(SegmentFrame);
}

Track Track::from_waypoints(std::vector<Waypoint> waypoints, double spacing_ft) {
  if (waypoints.size() < 4) throw std::invalid_argument("a track needs at least 4 waypoints, got " + std::to_string(waypoints.size()));
  if (!(spacing_ft > 0.0)) throw std::invalid_argument("track spacing must be > 0 ft");
  for (std::size_t k = 0; k < waypoints.size(); ++k) {
    const Waypoint& w = waypoints[k];
    if (!std::isfinite(w.p.n) || !std::isfinite(w.p.e) || !std::isfinite(w.p.u) || !(w.radius_ft > 0.0))
      throw std::invalid_argument("waypoint " + std::to_string(k) + " has a non-finite position or a radius <= 0");
    if (k > 0 && norm(w.p - waypoints[k - 1].p) < 10.0)
      throw std::invalid_argument("waypoints " + std::to_string(k - 1) + " and " + std::to_string(k) + " are closer than 10 ft");
  }
  Track t;
  t.waypoints_ = std::move(waypoints);
  t.build(spacing_ft);
  return t;
}

void Track::build(double spacing_ft) {
  spacing_ft_ = spacing_ft;
  std::vector<Vec3> dense;
  std::vector<double> dense_s, waypoint_s;
  sample_densely(waypoints_, &dense, &dense_s, &waypoint_s);
  resample(dense, dense_s, waypoint_s);
  build_frames();
  build_preview_table();
}

// The Catmull-Rom curve through the waypoints, densely in its parameter: points, cumulative
// chord length, and the arc length of each waypoint.
void Track::sample_densely(const std::vector<Waypoint>& waypoints, std::vector<Vec3>* dense_p,
                           std::vector<double>* dense_s_p, std::vector<double>* waypoint_s_p) {
  std::vector<Vec3>& dense = *dense_p;
  std::vector<double>& dense_s = *dense_s_p;
  std::vector<double>& waypoint_s = *waypoint_s_p;
  const std::size_t n = waypoints.size();
  std::vector<Vec3> w(n + 2);
  for (std::size_t k = 0; k < n; ++k) w[k + 1] = waypoints[k].p;
  w[0] = 2.0 * w[1] - w[2];  // phantom end points continue the first and last legs
  w[n + 1] = 2.0 * w[n] - w[n - 1];
  constexpr int kPerSegment = 400;
  dense.reserve((n - 1) * kPerSegment + 1);
  dense_s.reserve((n - 1) * kPerSegment + 1);
  waypoint_s.reserve(n);
  dense.push_back(w[1]);
  dense_s.push_back(0.0);
  waypoint_s.push_back(0.0);
  for (std::size_t k = 1; k < n; ++k) {
    const CatmullRomSegment segment(w[k - 1], w[k], w[k + 1], w[k + 2]);
    for (int i = 1; i <= kPerSegment; ++i) {
      const Vec3 q = segment.at(static_cast<double>(i) / kPerSegment);
      dense_s.push_back(dense_s.back() + norm(q - dense.back()));
      dense.push_back(q);
    }
    waypoint_s.push_back(dense_s.back());
  }
}

void Track::resample(const std::vector<Vec3>& dense, const std::vector<double>& dense_s,
                     const std::vector<double>& waypoint_s) {
  const double spacing_ft = spacing_ft_;
  // Resample uniformly in arc length; the track ends at the last whole sample, so every query
  // indexes samples directly (the dropped tail is shorter than one spacing).
  const int m = static_cast<int>(std::floor(dense_s.back() / spacing_ft)) + 1;
  length_ft_ = (m - 1) * spacing_ft;
  samples_.resize(m);
  std::size_t j = 0, wk = 0;
  for (int i = 0; i < m; ++i) {
    const double s = i * spacing_ft;
    while (j + 1 < dense_s.size() - 1 && dense_s[j + 1] < s) ++j;
    const double seg = dense_s[j + 1] - dense_s[j];
    const double f = seg > 0.0 ? (s - dense_s[j]) / seg : 0.0;
    samples_[i].p = dense[j] + f * (dense[j + 1] - dense[j]);
    while (wk + 2 < waypoint_s.size() && waypoint_s[wk + 1] < s) ++wk;
    const double g = std::clamp((s - waypoint_s[wk]) / (waypoint_s[wk + 1] - waypoint_s[wk]), 0.0, 1.0);
    samples_[i].radius_ft = waypoints_[wk].radius_ft + g * (waypoints_[wk + 1].radius_ft - waypoints_[wk].radius_ft);
  }
}

// Unit tangents, and the segment frames project() reads.
void Track::build_frames() {
  const int m = n_samples();
  tangents_.resize(m);
  for (int i = 0; i < m; ++i) {
    const int a = std::max(i - 1, 0), b = std::min(i + 1, m - 1);
    tangents_[i] = normalized(samples_[b].p - samples_[a].p);
  }
  frames_.resize(m - 1);
  for (int i = 0; i + 1 < m; ++i) {
    const Vec3 seg = samples_[i + 1].p - samples_[i].p;
    const double len = std::max(norm(seg), 1e-9);
    const Vec3 t = (1.0 / len) * seg;
    const double th = std::sqrt(t.n * t.n + t.e * t.e);
    SegmentFrame& g = frames_[i];
    g.pn = samples_[i].p.n;
    g.pe = samples_[i].p.e;
    g.pu = samples_[i].p.u;
    g.tn = static_cast<float>(t.n);
    g.te = static_cast<float>(t.e);
    g.tu = static_cast<float>(t.u);
    g.rn = static_cast<float>(th > 0.0 ? -t.e / th : 0.0);
    g.re = static_cast<float>(th > 0.0 ? t.n / th : 1.0);
    g.len_ft = static_cast<float>(len);
    g.inv_len = static_cast<float>(1.0 / len);
    g.radius_ft = static_cast<float>(samples_[i].radius_ft);
    g.dradius_ft = static_cast<float>(samples_[i + 1].radius_ft - samples_[i].radius_ft);
  }
}

void Track::build_preview_table() {
  const int m = n_samples();
  const double spacing_ft = spacing_ft_;
  // Preview table: samples every `stride`, continued along the end tangents with the end radii.
  const int stride = preview_stride(spacing_ft);
  preview_step_ft_ = stride * spacing_ft;
  const int n_entries = preview_entries(m, stride);
  preview_table_.resize(4 * static_cast<std::size_t>(n_entries));
  for (int t = 0; t < n_entries; ++t) {
    const int i = (t - 1) * stride;  // sample index of the entry, outside [0, m) past the ends
    Vec3 p;
    double r;
    if (i < 0) {
      p = samples_[0].p + (i * spacing_ft) * tangents_[0];
      r = samples_[0].radius_ft;
    } else if (i >= m) {
      p = samples_[m - 1].p + ((i - (m - 1)) * spacing_ft) * tangents_[m - 1];
      r = samples_[m - 1].radius_ft;
    } else {
      p = samples_[i].p;
      r = samples_[i].radius_ft;
    }
    float* e = &preview_table_[4 * static_cast<std::size_t>(t)];
    e[0] = static_cast<float>(p.n);
    e[1] = static_cast<float>(p.e);
    e[2] = static_cast<float>(p.u);
    e[3] = static_cast<float>(r);
  }
}

Vec3 Track::point_at(double s_ft) const {
  const double x = std::clamp(s_ft, 0.0, (n_samples() - 1) * spacing_ft_) / spacing_ft_;
  const int i = std::min(static_cast<int>(x), n_samples() - 2);
  const double f = x - i;
  return samples_[i].p + f * (samples_[i + 1].p - samples_[i].p);
}

double Track::radius_at(double s_ft) const {
  const double x = std::clamp(s_ft, 0.0, (n_samples() - 1) * spacing_ft_) / spacing_ft_;
  const int i = std::min(static_cast<int>(x), n_samples() - 2);
  const double f = x - i;
  return samples_[i].radius_ft + f * (samples_[i + 1].radius_ft - samples_[i].radius_ft);
}

void Track::preview(int n_agents, int n_points, double spacing_ft, const double* progress_ft, const double* pn,
                    const double* pe, const double* pu, float* d_n, float* d_e, float* d_u, float* radius_ft) const {
  // Uniform Catmull-Rom on the preview table, one vector pass over all (aircraft, point) pairs.
  // Indices rather than pointers, plain selects rather than std::min/max, and no member reads
  // in the loop: each of those stops GCC's vectoriser.
  const float* tab = preview_table_.data();  // [n_entries, 4]
  const double s_max = length_ft_, inv_step = 1.0 / preview_step_ft_;
  const int j_max = static_cast<int>(preview_table_.size() / 4) - 4;  // entries j .. j+3 are read
  const int n = n_agents * n_points;
  const float inv_points = 1.0f / static_cast<float>(n_points);
#pragma omp simd
  for (int k = 0; k < n; ++k) {
    const int a = preview_agent(k, inv_points);
    const int p = k - a * n_points;
    const double s_raw = progress_ft[a] + (p + 1) * spacing_ft;
    const double x = (s_raw < 0.0 ? 0.0 : (s_raw > s_max ? s_max : s_raw)) * inv_step;
    const int j = static_cast<int>(x) < j_max ? static_cast<int>(x) : j_max;
    const float f = static_cast<float>(x - j), f2 = f * f, f3 = f2 * f;
    // Weights of entries j .. j+3, i.e. of the table points at (j-1, j, j+1, j+2) steps.
    const float w0 = 0.5f * (-f3 + 2.0f * f2 - f), w1 = 0.5f * (3.0f * f3 - 5.0f * f2 + 2.0f);
    const float w2 = 0.5f * (-3.0f * f3 + 4.0f * f2 + f), w3 = 0.5f * (f3 - f2);
    const int o = 4 * j;
    d_n[k] = w0 * tab[o] + w1 * tab[o + 4] + w2 * tab[o + 8] + w3 * tab[o + 12] - static_cast<float>(pn[a]);
    d_e[k] = w0 * tab[o + 1] + w1 * tab[o + 5] + w2 * tab[o + 9] + w3 * tab[o + 13] - static_cast<float>(pe[a]);
    d_u[k] = w0 * tab[o + 2] + w1 * tab[o + 6] + w2 * tab[o + 10] + w3 * tab[o + 14] - static_cast<float>(pu[a]);
    radius_ft[k] = w0 * tab[o + 3] + w1 * tab[o + 7] + w2 * tab[o + 11] + w3 * tab[o + 15];
  }
}

void Track::prefetch(int n_agents, const int* hints, const double* progress_ft, double horizon_ft) const {
  // project() from hint h reads segment h, h + 1 when the aircraft has passed h's end (about
  // every other step) and h - 1 otherwise.
  const int n_frames = static_cast<int>(frames_.size());
  for (int a = 0; a < n_agents; ++a) {
    const int h = hints[a];
    for (int k = std::max(h - 1, 0); k <= h + 1 && k < n_frames; ++k) __builtin_prefetch(&frames_[k]);
  }
  double lo = progress_ft[0], hi = progress_ft[0];
  for (int a = 1; a < n_agents; ++a) lo = std::min(lo, progress_ft[a]), hi = std::max(hi, progress_ft[a]);
  const int n_entries = static_cast<int>(preview_table_.size() / 4);
  const int j0 = std::clamp(static_cast<int>(lo / preview_step_ft_), 0, n_entries - 1);
  const int j1 = std::clamp(static_cast<int>((hi + horizon_ft) / preview_step_ft_) + 4, 0, n_entries - 1);
  for (int j = j0; j <= j1; j += 4) __builtin_prefetch(&preview_table_[4 * static_cast<std::size_t>(j)]);
  __builtin_prefetch(&preview_table_[4 * static_cast<std::size_t>(j1)]);
}

TrackFrame Track::frame_at(double s_ft) const {
  const double x = std::clamp(s_ft, 0.0, (n_samples() - 1) * spacing_ft_) / spacing_ft_;
  const int i = std::min(static_cast<int>(x), n_samples() - 2);
  const double f = x - i;
  TrackFrame fr;
  fr.center = samples_[i].p + f * (samples_[i + 1].p - samples_[i].p);
  fr.tangent = normalized(tangents_[i] + f * (tangents_[i + 1] - tangents_[i]));
  fr.right = normalized(cross(Vec3{0.0, 0.0, 1.0}, fr.tangent));
  fr.up = cross(fr.tangent, fr.right);
  fr.radius_ft = samples_[i].radius_ft + f * (samples_[i + 1].radius_ft - samples_[i].radius_ft);
  return fr;
}

TrackQuery Track::project(const Vec3& pos, int hint) const {
  const int m = n_samples(), n_seg = m - 1;
  int a;
  if (hint < 0 || hint >= m) {
    // Cold start (reset, or a user's one-off query): the nearest sample by a global scan.
    a = 0;
    double best = 1e300;
    for (int k = 0; k < m; ++k) {
      const Vec3 d = pos - samples_[k].p;
      const double v = dot(d, d);
      if (v < best) best = v, a = k;
    }
  } else {
    a = hint;
  }
  a = std::min(a, n_seg - 1);
  // How far `pos` lies beyond the end of segment k, along it (> 0: passed).
  auto beyond = [&](int k) {
    const SegmentFrame& g = frames_[k];
    return (pos.n - g.pn) * g.tn + (pos.e - g.pe) * g.te + (pos.u - g.pu) * g.tu - g.len_ft;
  };
  // The first segment whose end is not passed. Tracks never fold back within a tube radius, so
  // this is unique near the aircraft and the walk from any nearby start finds it.
  while (a + 1 < n_seg && beyond(a) > 0.0) ++a;
  while (a > 0 && beyond(a - 1) <= 0.0) --a;
  const SegmentFrame& g = frames_[a];
  const double dn = pos.n - g.pn, de = pos.e - g.pe, du = pos.u - g.pu;
  const double f = std::clamp((dn * g.tn + de * g.te + du * g.tu) * g.inv_len, 0.0, 1.0);
  TrackQuery q;
  q.s_ft = (a + f) * spacing_ft_;
  q.index = a;
  // Right and up are perpendicular to the segment, so the offsets from its start are the
  // offsets from the closest point.
  const double un = -static_cast<double>(g.tu) * g.re, ue = static_cast<double>(g.tu) * g.rn;
  const double uu = static_cast<double>(g.tn) * g.re - static_cast<double>(g.te) * g.rn;
  q.lateral_ft = dn * g.rn + de * g.re;
  q.vertical_ft = dn * un + de * ue + du * uu;
  q.dist_ft = std::sqrt(q.lateral_ft * q.lateral_ft + q.vertical_ft * q.vertical_ft);
  q.radius_ft = g.radius_ft + f * g.dradius_ft;
  return q;
}

Track Track::load_csv(const std::string& path, double spacing_ft) {
  const io::CsvTable t = io::CsvTable::read(path);
  for (const char* c : {"pn_ft", "pe_ft", "alt_ft", "radius_ft"})
    if (!t.has_column(c)) throw io::CsvError(path + ": missing column '" + c + "' (a track file has pn_ft, pe_ft, alt_ft, radius_ft)");
  const std::vector<double> n = t.numeric("pn_ft"), e = t.numeric("pe_ft"), u = t.numeric("alt_ft"),
                            r = t.numeric("radius_ft");
  std::vector<Waypoint> w;
  for (std::size_t k = 0; k < n.size(); ++k) w.push_back({{n[k], e[k], u[k]}, r[k]});
  try {
    return from_waypoints(std::move(w), spacing_ft);
  } catch (const std::invalid_argument& ex) {
    throw io::CsvError(path + ": " + ex.what());
  }
}

void Track::save_csv(const std::string& path) const {
  std::vector<std::vector<double>> cols(4);
  for (const Waypoint& w : waypoints_) {
    cols[0].push_back(w.p.n);
    cols[1].push_back(w.p.e);
    cols[2].push_back(w.p.u);
    cols[3].push_back(w.radius_ft);
  }
  io::write_csv(path, {"pn_ft", "pe_ft", "alt_ft", "radius_ft"}, cols);
}

}  // namespace f16race::race
