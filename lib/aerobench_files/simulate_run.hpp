#pragma once
// `f16race simulate` without its command line: one F-16 flown against a reference trajectory, a
// scripted command file or one of AeroBench's autopilots (a batch of aircraft when the start file
// has several rows), or the model's derivatives at the points of a file; the result written to a
// CSV in the AeroBench format. The command prints the outcomes. Torch-free; bad input raises
// io::InputError naming the option or file and the fix.
#include <cstddef>
#include <string>
#include <vector>

#include "aerobench_files/aerobench_csv.hpp"
#include "dynamics/f16_batch.hpp"
#include "dynamics/state.hpp"

namespace f16race::aerobench_files {

// The simulate command's options, as given.
struct SimulateRequest {
  std::string model = "morelli";
  std::string integrator = "rk4";
  std::string interp = "hold";
  std::string reference;
  std::string derivatives;
  std::string commands;
  std::string autopilot;  // gcas | waypoint: the outer loop flown natively
  std::string waypoints;
  std::string init;
  std::string out;
  double dt_s = 0.01;
  double trim_vt_ftps = 540.0;
  double trim_alt_ft = 5000.0;
  double duration_s = 15.0;
  double sample_s = 0.02;
  bool sample_given = false;
  bool compare = false;
};

// Refuses sources that contradict each other (--reference with --commands, --init with
// --reference, ...).
void check_sources(const SimulateRequest& request);

// One trajectory, written to request.out.
struct TrajectoryOutcome {
  std::size_t samples = 0;
  dynamics::AeroModel model = dynamics::AeroModel::kMorelli;
  dynamics::Integrator integrator = dynamics::Integrator::kRk4;
  double dt_s = 0.0;
  bool autopilot = false, autopilot_finished = false;
  bool has_reference = false;       // --reference given: `comparison` holds its columns when --compare
  std::vector<ColumnDiff> comparison;  // largest absolute difference per column
};

// An autopilot batch (--init with several rows), one summary row per aircraft written to request.out.
struct BatchOutcome {
  std::size_t aircraft = 0;
  double duration_s = 0.0;  // the last output time
  dynamics::AeroModel model = dynamics::AeroModel::kMorelli;
  dynamics::Integrator integrator = dynamics::Integrator::kRk4;
  double dt_s = 0.0;
  double wall_s = 0.0;
  int failed = 0, finished = 0, below_ground = 0;  // aircraft
  double lowest_alt_ft = 0.0;
};

struct SimulateOutcome {
  bool is_batch = false;  // which of the two below
  TrajectoryOutcome trajectory;
  BatchOutcome batch;
};

// Flies the request (not a derivatives one). An aircraft that leaves the envelope is an
// io::InputError after the rows up to then are written.
SimulateOutcome simulate_to_file(const SimulateRequest& request);

// The model at every point of request.derivatives, written to request.out.
struct DerivativesOutcome {
  std::size_t points = 0;
  bool closed_loop = false;
  dynamics::AeroModel model = dynamics::AeroModel::kMorelli;
  std::vector<ColumnDiff> comparison;  // with --compare: largest relative difference of the model's values
};
DerivativesOutcome derivatives_to_file(const SimulateRequest& request);

}  // namespace f16race::aerobench_files
