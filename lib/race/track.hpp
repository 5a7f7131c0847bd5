#pragma once
// A race track: a smooth 3-D center-line through random waypoints, each with its own tube
// radius, resampled at a fixed arc-length spacing so queries for many aircraft are O(1) each.
// Coordinates are AeroBench's: north, east, altitude (up), in feet.
#include <algorithm>
#include <cmath>
#include <memory_resource>
#include <string>
#include <vector>

#include "random/random_stream.hpp"

namespace f16race::race {

struct Vec3 {
  double n = 0.0, e = 0.0, u = 0.0;  // north, east, up [ft]
};
inline Vec3 operator+(Vec3 a, Vec3 b) { return {a.n + b.n, a.e + b.e, a.u + b.u}; }
inline Vec3 operator-(Vec3 a, Vec3 b) { return {a.n - b.n, a.e - b.e, a.u - b.u}; }
inline Vec3 operator*(double k, Vec3 a) { return {k * a.n, k * a.e, k * a.u}; }
inline double dot(Vec3 a, Vec3 b) { return a.n * b.n + a.e * b.e + a.u * b.u; }
inline double norm(Vec3 a) { return std::sqrt(dot(a, a)); }

struct Waypoint {
  Vec3 p;            // [ft]
  double radius_ft;  // tube radius around the center-line here
};

// How random tracks are drawn. Angles in degrees, lengths in feet.
struct TrackConfig {
  int n_waypoints = 6;
  double leg_min_ft = 5000.0;
  double leg_max_ft = 8000.0;
  double max_turn_deg = 30.0;          // heading change between consecutive legs
  double max_heading_dev_deg = 80.0;   // from the first leg: keeps the track from crossing itself
  double max_climb_deg = 5.0;          // climb/descent angle of a leg
  double max_climb_change_deg = 4.0;   // change of climb angle between legs
  double alt_min_ft = 5000.0;          // center-line altitude band
  double alt_max_ft = 15000.0;
  double radius_min_ft = 900.0;
  double radius_max_ft = 1800.0;
  double spacing_ft = 100.0;           // arc-length resolution of the resampled center-line
};

// Local tube geometry at arc length s.
struct TrackFrame {
  Vec3 center;   // center-line point [ft]
  Vec3 tangent;  // unit, along the track
  Vec3 right;    // unit, horizontal, to the right of the tangent
  Vec3 up;       // unit, tangent x right
  double radius_ft;
};

// Where an aircraft is relative to the track.
struct TrackQuery {
  double s_ft;         // arc length of the closest center-line point (progress)
  int index;           // sample index, the warm start for the next query
  double lateral_ft;   // offset to the right of the center-line
  double vertical_ft;  // offset above the center-line (in the tube's cross-section)
  double dist_ft;      // distance from the center-line
  double radius_ft;    // local tube radius
};

class Track {
 public:
  Track() = default;
  // An empty track whose arrays live in `memory` (see RaceEnv: one huge-page block for all
  // envs), with room for the longest track `config` can generate, so regenerating it never
  // reallocates. Assigning another track into it copies the arrays into that memory; copies of
  // it own ordinary heap memory.
  Track(std::pmr::memory_resource* memory, const TrackConfig& config);
  // Samples of the longest track `config` can generate (every leg at its maximum, with a
  // generous allowance for the spline's arc exceeding the chord): the capacity to reserve.
  static int max_samples(const TrackConfig& config);
  // Bytes that Track(memory, config) takes from `memory`, alignment padding included.
  static std::size_t storage_bytes(const TrackConfig& config);
  // Random track from `rng`; deterministic for a given stream state on every machine.
  static Track generate(const TrackConfig& config, RandomStream& rng);
  // Center-line through given waypoints (at least 4); throws std::invalid_argument otherwise.
  static Track from_waypoints(std::vector<Waypoint> waypoints, double spacing_ft = 100.0);

  // CSV with columns pn_ft, pe_ft, alt_ft, radius_ft, one waypoint per row.
  static Track load_csv(const std::string& path, double spacing_ft = 100.0);
  void save_csv(const std::string& path) const;

  const std::vector<Waypoint>& waypoints() const { return waypoints_; }
  double length_ft() const { return length_ft_; }
  double spacing_ft() const { return spacing_ft_; }
  int n_samples() const { return static_cast<int>(samples_.size()); }

  // Geometry at arc length s (clamped to [0, length]).
  TrackFrame frame_at(double s_ft) const;
  Vec3 point_at(double s_ft) const;  // center-line point only: cheaper than frame_at
  // Point and radius in one look-up; inline: the observations call it for every preview point.
  Vec3 sample(double s_ft, double* radius_ft) const {
    const double x = std::clamp(s_ft, 0.0, (n_samples() - 1) * spacing_ft_) / spacing_ft_;
    const int i = std::min(static_cast<int>(x), n_samples() - 2);
    const double f = x - i;
    const Sample& a = samples_[i];
    const Sample& b = samples_[i + 1];
    *radius_ft = a.radius_ft + f * (b.radius_ft - a.radius_ft);
    return a.p + f * (b.p - a.p);
  }
  double radius_at(double s_ft) const;
  // The observations' track preview for n_agents aircraft: point p (0 .. n_points-1) of aircraft
  // a is the center-line at arc length progress_ft[a] + (p + 1) * spacing_ft (clamped to [0,
  // length]), written relative to the aircraft's position (pn, pe, pu [ft]) with the local
  // radius, as float, at k = a * n_points + p of each output. Inputs are the env's contiguous
  // per-aircraft arrays, read directly: staging them per point with scalar stores would stall
  // the vector loop until the store buffer drains.
  // Read from the preview table (cubic interpolation every preview_step_ft()), not the samples:
  // within ~0.1 ft of sample()'s point on average and ~2 ft at worst, and of its radius away
  // from waypoints (up to ~20 ft where the radius changes slope at one); see docs/race.md.
  void preview(int n_agents, int n_points, double spacing_ft, const double* progress_ft, const double* pn,
               const double* pe, const double* pu, float* d_n, float* d_e, float* d_u, float* radius_ft) const;
  // The aircraft a of preview index k = a * n_points + p, given 1 / n_points: a float multiply
  // instead of an integer division, which GCC does not vectorise (exact for k < 2^20). Forced
  // inline: an outlined call, even an inlinable one, stops the `omp simd` loops that use it.
  [[gnu::always_inline]] static int preview_agent(int k, float inv_points) {
    return static_cast<int>((static_cast<float>(k) + 0.5f) * inv_points);
  }
  // Starts loading what project() from hints[a] and preview() from progress_ft[a] up to
  // horizon_ft ahead will read, for n_agents aircraft: called one env ahead so those cache
  // misses overlap the current env's work.
  void prefetch(int n_agents, const int* hints, const double* progress_ft, double horizon_ft) const;
  // Arc-length step of the preview table: the sample spacing times a whole number, ~500 ft.
  double preview_step_ft() const { return preview_step_ft_; }
  static int preview_stride(double spacing_ft);  // that whole number, for a sample spacing

  // Closest center-line point to `pos`, searched from `hint` (a previous answer's index, or
  // -1 for a global search). A warm-started call walks only a few segments: O(1). The answer is
  // on the first segment whose end the aircraft has not passed, so warm and cold searches agree.
  TrackQuery project(const Vec3& pos, int hint) const;

 private:
  void build(double spacing_ft);  // the samples, frames and preview table from waypoints_
  static void sample_densely(const std::vector<Waypoint>& waypoints, std::vector<Vec3>* dense,
                             std::vector<double>* dense_s_ft, std::vector<double>* waypoint_s_ft);
  void resample(const std::vector<Vec3>& dense, const std::vector<double>& dense_s_ft,
                const std::vector<double>& waypoint_s_ft);
  void build_frames();
  void build_preview_table();
  std::vector<Waypoint> waypoints_;
  // Center-line point and radius packed together: one cache line serves both, which matters
  // when a thousand envs each read their own track every step.
  struct Sample {
    Vec3 p;
    double radius_ft;
  };
  std::pmr::vector<Sample> samples_;  // [n_samples] every spacing_ft of arc length
  std::pmr::vector<Vec3> tangents_;   // [n_samples] unit tangents
  // Everything project() needs about segment a (sample a to a+1) in one cache line. The frame
  // vectors are float: their rounding moves offsets by ~1e-4 ft at 1 000 ft.
  struct alignas(64) SegmentFrame {
    double pn, pe, pu;         // sample a [ft]
    float tn, te, tu;          // unit direction to sample a+1
    float rn, re;              // unit right, horizontal (up = t x right)
    float len_ft, inv_len;     // chord length to sample a+1, its inverse
    float radius_ft, dradius_ft;  // radius at sample a, change to sample a+1
  };
  std::pmr::vector<SegmentFrame> frames_;  // [n_samples - 1]
  // Center-line point and radius every preview_step_ft_ of arc length, as float, entry t at arc
  // length (t - 1) * step, continued straight past both ends so the cubic never leaves the
  // table. Its ~25 entries per 12 000 ft of preview sit in a few cache lines shared by the
  // whole pack; the samples behind the same 48 preview points are ~60 scattered lines, and
  // fetching those was the observations' largest cost.
  std::pmr::vector<float> preview_table_;  // [n_entries, 4]: n, e, u [ft], radius [ft]
  double preview_step_ft_ = 500.0;
  double spacing_ft_ = 100.0;
  double length_ft_ = 0.0;
};

}  // namespace f16race::race
