#include "dynamics/autopilot_batch.hpp"

#include <algorithm>
#include <cmath>
#include <stdexcept>

namespace f16race::dynamics {
namespace {

// Per-aircraft discrete state of the batch's law, written into the law rows after each update.
struct Modes {
  std::vector<GcasState> gcas;        // [n] (GCAS)
  std::vector<WaypointState> wp;      // [n] (waypoint)
};

const std::vector<Waypoint>& waypoints_of(const AutopilotBatchRequest& r, int i) {
  return r.waypoints.size() == 1 ? r.waypoints.front() : r.waypoints[static_cast<std::size_t>(i)];
}

void write_law_row(const AutopilotBatchRequest& r, const Modes& m, int i, F16Batch* b) {
  if (r.law == StageLaw::kGcas) {
    b->law(kLawMode)[i] = static_cast<double>(static_cast<int>(m.gcas[static_cast<std::size_t>(i)].mode));
    return;
  }
  const std::vector<Waypoint>& wps = waypoints_of(r, i);
  const int k = m.wp[static_cast<std::size_t>(i)].index;
  const bool done = k >= static_cast<int>(wps.size());
  const Waypoint& w = done ? wps.back() : wps[static_cast<std::size_t>(k)];
  b->law(kLawMode)[i] = done ? 1.0 : 0.0;
  b->law(kLawTargetN)[i] = w.n_ft;
  b->law(kLawTargetE)[i] = w.e_ft;
  b->law(kLawTargetAlt)[i] = w.alt_ft;
  b->law(kLawAirspeed)[i] = WaypointConstants::kAirspeedFtps;
}

std::string mode_name(const AutopilotBatchRequest& r, const Modes& m, int i) {
  if (r.law == StageLaw::kGcas) return gcas_mode_name(m.gcas[static_cast<std::size_t>(i)].mode);
  const int k = m.wp[static_cast<std::size_t>(i)].index;
  return k >= static_cast<int>(waypoints_of(r, i).size()) ? "Done" : "Waypoint " + std::to_string(k + 1);
}

void check(const AutopilotBatchRequest& r) {
  const std::size_t n = r.x0.size();
  if (n == 0) throw std::invalid_argument("autopilot batch: no aircraft");
  if (!(r.dt_s > 0.0)) throw std::invalid_argument("autopilot batch: dt must be > 0");
  if (r.law == StageLaw::kGcas) {
    if (!r.gcas_modes.empty() && r.gcas_modes.size() != n)
      throw std::invalid_argument("autopilot batch: " + std::to_string(r.gcas_modes.size()) + " GCAS start modes for " +
                                  std::to_string(n) + " aircraft");
  } else if (r.law == StageLaw::kWaypoint) {
    if (r.waypoints.size() != 1 && r.waypoints.size() != n)
      throw std::invalid_argument("autopilot batch: give one waypoint list, or one per aircraft");
    for (const auto& w : r.waypoints)
      if (w.empty()) throw std::invalid_argument("the waypoint autopilot needs at least one waypoint");
  } else {
    throw std::invalid_argument("autopilot batch: the law must be gcas or waypoint");
  }
  for (std::size_t k = 1; k < r.output_times_s.size(); ++k)
    if (!(r.output_times_s[k] > r.output_times_s[k - 1]))
      throw std::invalid_argument("autopilot batch: output times must increase strictly");
}

// Flies the batch from t0 to t1 in equal steps no longer than dt that land exactly on t1 (as
// replay_references), noting each aircraft's failure and when. `before` is scratch, [n].
void advance_to(double t0, double t1, double dt_s, F16Batch* batch, std::vector<std::int32_t>* before,
                AutopilotBatchResult* result) {
  const int n = static_cast<int>(before->size());
  const int steps = std::max(1, static_cast<int>(std::ceil((t1 - t0) / dt_s - 1e-9)));
  const double h = (t1 - t0) / steps;
  for (int s = 0; s < steps; ++s) {
    std::copy(batch->status(), batch->status() + n, before->begin());
    if (batch->step(h, 1) == 0) continue;
    const double t_end = (s + 1 == steps) ? t1 : t0 + s * h + h;
    for (int i = 0; i < n; ++i)
      if ((*before)[static_cast<std::size_t>(i)] == kStatusOk && batch->status()[i] != kStatusOk) {
        result->aircraft[static_cast<std::size_t>(i)].status = batch->status()[i];
        result->aircraft[static_cast<std::size_t>(i)].failed_at_s = t_end;
      }
  }
}

}  // namespace

AutopilotBatchResult fly_autopilot_batch(const AutopilotBatchRequest& r, const AutopilotSampleFn& on_sample) {
  check(r);
  const int n = static_cast<int>(r.x0.size());
  AutopilotBatchResult result;
  result.aircraft.resize(static_cast<std::size_t>(n));
  const std::vector<double>& times = r.output_times_s;
  if (times.empty()) return result;

  F16BatchConfig cfg;
  cfg.n_env = n;
  cfg.n_agent = 1;
  cfg.model = r.model;
  cfg.integrator = r.integrator;
  cfg.limits = r.limits;
  cfg.stage_law = r.law;
  F16Batch batch(cfg);
  Modes modes;
  if (r.law == StageLaw::kGcas) modes.gcas.resize(static_cast<std::size_t>(n));
  else modes.wp.resize(static_cast<std::size_t>(n));
  for (int i = 0; i < n; ++i) {
    batch.reset_aircraft(i, r.x0[static_cast<std::size_t>(i)], RefVector{});
    if (r.law == StageLaw::kGcas && !r.gcas_modes.empty())
      modes.gcas[static_cast<std::size_t>(i)].mode = r.gcas_modes[static_cast<std::size_t>(i)];
  }

  std::vector<char> sampled(static_cast<std::size_t>(n), 0);
  // A sample: for every flying aircraft the discrete update on the sampled state, then the
  // outputs under the new mode (replay_references' record), then the stop rule.
  auto record = [&](double t) {
    for (int i = 0; i < n; ++i) {
      sampled[static_cast<std::size_t>(i)] = batch.status()[i] == kStatusOk;
      if (!sampled[static_cast<std::size_t>(i)]) continue;
      const StateVector x = batch.aircraft_state(i);
      if (r.law == StageLaw::kGcas) gcas_advance(&modes.gcas[static_cast<std::size_t>(i)], t, x.data());
      else waypoint_advance(waypoints_of(r, i), &modes.wp[static_cast<std::size_t>(i)], t, x.data());
      write_law_row(r, modes, i, &batch);
      AutopilotAircraftResult& a = result.aircraft[static_cast<std::size_t>(i)];
      if (a.samples == 0 || x[kAlt] < a.min_alt_ft) {
        a.min_alt_ft = x[kAlt];
        a.min_alt_t_s = t;
      }
      ++a.samples;
      a.x_last = x;
      a.mode = mode_name(r, modes, i);
    }
    batch.evaluate_outputs();
    if (on_sample) on_sample(t, batch, sampled);
    for (int i = 0; i < n; ++i) {
      if (!sampled[static_cast<std::size_t>(i)]) continue;
      const bool done = r.law == StageLaw::kWaypoint &&
                        waypoint_finished(waypoints_of(r, i), modes.wp[static_cast<std::size_t>(i)], t);
      if (done) {
        AutopilotAircraftResult& a = result.aircraft[static_cast<std::size_t>(i)];
        a.finished = true;
        a.finished_at_s = t;
        batch.status()[i] = kStatusRetired;  // frozen from here on
      }
    }
  };
  record(times[0]);

  std::vector<std::int32_t> before(static_cast<std::size_t>(n));
  for (std::size_t k = 0; k + 1 < times.size(); ++k) {
    advance_to(times[k], times[k + 1], r.dt_s, &batch, &before, &result);
    record(times[k + 1]);
    bool any_flying = false;
    for (int i = 0; i < n && !any_flying; ++i) any_flying = batch.status()[i] == kStatusOk;
    if (!any_flying) break;
  }
  return result;
}

}  // namespace f16race::dynamics
