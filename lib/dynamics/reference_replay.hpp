#pragma once
// One aircraft flown against a time series of outer-loop references: the engine behind
// `f16race simulate`, used to compare this model with AeroBench's own trajectories and to run
// scripted manoeuvres. Fixed-step RK4/Euler; references are evaluated at every stage, from
// recorded samples or from an autopilot (OuterLoop) whose mode changes at output samples.
#include <string>
#include <vector>

#include "dynamics/envelope.hpp"
#include "dynamics/f16_batch.hpp"
#include "dynamics/outer_loop.hpp"
#include "dynamics/state.hpp"

namespace f16race::dynamics {

enum class RefInterp {
  kHold,    // latest sample at or before t (1e-9 s tolerance): exact for step inputs
  kLinear,  // linear between samples, held flat beyond the ends: for smooth inputs. With
            // segments, never across a segment change: the last interval of a segment is
            // extrapolated from its last two samples and the new segment starts with a jump.
};

// Reference samples: t_s [n] strictly increasing, values[r] [n] for each RefIndex r.
struct ReferenceSeries {
  std::vector<double> t_s;
  std::vector<double> values[kNumRefs];
  RefInterp interp = RefInterp::kHold;
  // Optional [n] segment id per sample (e.g. an autopilot's discrete mode); empty = one segment.
  std::vector<int> segment;

  // References at time t. With hold, `left_limit` asks for the value just before t, which is
  // what the last stage of a step ending on a switch time must see (AeroBench restarts its
  // integrator at a switch, so the old value holds up to it).
  RefVector at(double t, bool left_limit = false) const;
};

struct ReplayRequest {
  AeroModel model = AeroModel::kMorelli;
  Integrator integrator = Integrator::kRk4;
  double dt_s = 0.01;                 // largest step; shortened to land on every output time
  StateVector x0{};
  ReferenceSeries refs;
  // When set, the references come from this autopilot instead of `refs` (not owned; its mode
  // advances during the replay, at the start time and at every output time).
  OuterLoop* autopilot = nullptr;
  std::vector<double> output_times_s;  // strictly increasing; the first is the start time
  EnvelopeLimits limits{};
};

// One output row: the state and what AeroBench's controlled_f16 reports at it.
struct ReplaySample {
  double t_s;
  StateVector x;
  StateVector xdot;
  RefVector u_ref;
  double nz_g, ps_radps, ny_r, ny_g;
  double throttle, elevator_deg, aileron_deg, rudder_deg;
  std::string mode;  // the autopilot's mode after its update at this sample; empty without one
};

struct ReplayResult {
  std::vector<ReplaySample> samples;  // one per output time reached
  std::int32_t status = kStatusOk;    // non-ok: the run stopped early; samples end before it
  double failed_at_s = 0.0;
  bool autopilot_finished = false;    // the autopilot's stop rule ended the run at the last sample
};

ReplayResult replay_references(const ReplayRequest& request);

// Closed-loop evaluation at one point (no integration), in the layout of a ReplaySample.
ReplaySample evaluate_closed_loop(AeroModel model, double t_s, const StateVector& x, const RefVector& u_ref);

}  // namespace f16race::dynamics
