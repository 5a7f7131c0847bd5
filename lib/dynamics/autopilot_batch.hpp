#pragma once
// Many F-16s flown at once by one of AeroBench's autopilots (GCAS or waypoint): an F16Batch with
// the law evaluated at every RK stage of every lane, the discrete modes advanced at the output
// samples, per aircraft, exactly as replay_references does for one aircraft (and AeroBench's
// run_f16_sim): at the start time and after every output interval, the mode update on the
// sampled state, then the autopilot's stop rule. For Monte-Carlo checks of a law over initial
// conditions (does GCAS recover from every one?) at the simulator's speed.
#include <cstdint>
#include <functional>
#include <string>
#include <vector>

#include "dynamics/envelope.hpp"
#include "dynamics/f16_batch.hpp"
#include "dynamics/gcas_autopilot.hpp"
#include "dynamics/state.hpp"
#include "dynamics/waypoint_autopilot.hpp"

namespace f16race::dynamics {

struct AutopilotBatchRequest {
  AeroModel model = AeroModel::kMorelli;
  Integrator integrator = Integrator::kRk4;
  double dt_s = 0.01;                   // largest step; shortened to land on every output time
  StageLaw law = StageLaw::kGcas;       // kGcas or kWaypoint
  std::vector<StateVector> x0;          // [n] start states, one aircraft each
  std::vector<GcasMode> gcas_modes;     // GCAS: [n] start modes, or empty (standby)
  // Waypoint: [n] lists, or [1] shared by every aircraft; each non-empty.
  std::vector<std::vector<Waypoint>> waypoints;
  std::vector<double> output_times_s;   // strictly increasing; the first is the start time
  EnvelopeLimits limits{};
};

struct AutopilotAircraftResult {
  std::int32_t status = kStatusOk;  // non-ok: left the envelope at failed_at_s (state: the last valid)
  double failed_at_s = 0.0;
  bool finished = false;            // the autopilot's stop rule ended it at finished_at_s
  double finished_at_s = 0.0;
  int samples = 0;                  // output samples reached (as replay_references would return)
  double min_alt_ft = 0.0;          // lowest sampled altitude and when
  double min_alt_t_s = 0.0;
  StateVector x_last{};             // state at the last sample reached
  std::string mode;                 // autopilot mode at the last sample ("pull", "Waypoint 3", "Done")
};

struct AutopilotBatchResult {
  std::vector<AutopilotAircraftResult> aircraft;  // [n]
};

// Called at every output sample, after the mode update and evaluate_outputs(): the batch's
// state, reference and output rows are the sample's. `sampled[i]`: aircraft i is recorded at
// this time (it was flying and has not left the envelope).
using AutopilotSampleFn = std::function<void(double t_s, const F16Batch& batch, const std::vector<char>& sampled)>;

// Throws std::invalid_argument on an inconsistent request (sizes, empty lists, times).
AutopilotBatchResult fly_autopilot_batch(const AutopilotBatchRequest& request, const AutopilotSampleFn& on_sample = {});

}  // namespace f16race::dynamics
