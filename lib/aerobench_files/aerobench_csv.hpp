#pragma once
// One F-16 to and from CSV files in the AeroBench reference format (the files under
// tests/data, see its README): a reference trajectory or a scripted command file becomes a
// replay request, a replay becomes trajectory rows with the same column names, and a file of
// derivative points becomes our model's values at each point. Used by `f16race simulate` and by
// the tests that hold the model to AeroBench, so the files are read one way everywhere.
// Torch-free; bad files raise io::InputError (or io::CsvError) naming the file and the fix.
#include <cstddef>
#include <string>
#include <vector>

#include "dynamics/reference_replay.hpp"
#include "dynamics/waypoint_autopilot.hpp"
#include "io/csv_table.hpp"

namespace f16race::aerobench_files {

// How to fly a request, whichever file it comes from.
struct ReplaySettings {
  dynamics::AeroModel model = dynamics::AeroModel::kMorelli;
  dynamics::Integrator integrator = dynamics::Integrator::kRk4;
  dynamics::RefInterp interp = dynamics::RefInterp::kHold;
  double dt_s = 0.01;
};

// From a reference trajectory: the start state from its first row, the outer-loop references
// (Nz_ref_g, ps_ref_radps, Ny_r_ref_mixed, throttle_ref_delta) at every row's t_s, outputs at the
// same times. An autopilot's `mode` column, where present, splits the references into segments
// (references jump there and are never interpolated across).
dynamics::ReplayRequest request_from_reference(const io::CsvTable& reference, const ReplaySettings& settings);

// A scripted manoeuvre: trimmed level flight at (vt, alt), then the command file's reference
// columns as offsets from the trim references (none given: fly the trim), sampled every
// sample_s for duration_s.
struct ScriptedRun {
  double trim_vt_ftps = 540.0;
  double trim_alt_ft = 5000.0;
  double duration_s = 15.0;
  double sample_s = 0.02;
  static constexpr double kMaxSamples = 1e7;  // beyond it a typo, not a trajectory
};
// `commands` may be null (fly the trim).
dynamics::ReplayRequest request_from_commands(const io::CsvTable* commands, const ScriptedRun& run,
                                              const ReplaySettings& settings);

// Autopilot runs (`simulate --autopilot`). Waypoints: columns e_ft, n_ft, alt_ft, one waypoint a
// row, in order (AeroBench's (east, north, altitude) tuples).
std::vector<dynamics::Waypoint> read_waypoints(const io::CsvTable& waypoints);
// The first row's `mode` column (an autopilot's initial mode), or "" when there is none.
std::string initial_mode(const io::CsvTable& table);
// No reference: the start state from the first row of `init` (the state columns of the
// reference format; the three integrators may be left out and start at 0), outputs every
// sample_s from 0 while <= duration_s, the times accumulated (t += sample_s) as AeroBench's are.
dynamics::ReplayRequest request_from_initial_state(const io::CsvTable& init, double duration_s, double sample_s,
                                                   const ReplaySettings& settings);
// Every row of `init` as a start state, read as request_from_initial_state reads the first.
std::vector<dynamics::StateVector> initial_states(const io::CsvTable& init);
// Every row's `mode` cell ("" for all when the column is missing).
std::vector<std::string> row_modes(const io::CsvTable& table);
// Output times every sample_s from 0 while <= duration_s, accumulated as AeroBench's are;
// InputError for non-positive values or more than ScriptedRun::kMaxSamples samples.
std::vector<double> sample_times(double duration_s, double sample_s);

// Trajectory columns: t_s, the 16 states, Nz_g, ps_radps, Ny_r_mixed, Ny_g, the 4 references,
// the 4 surfaces and the 16 state derivatives: the reference format minus `mode`.
std::vector<std::string> trajectory_header();
// rows[sample][column] in trajectory_header's order.
std::vector<std::vector<double>> trajectory_rows(const dynamics::ReplayResult& result);

// Our model at every row of a derivative-points file: closed-loop points (16 states and the 4
// references, deriv_closed_loop_*) or plant points (13 states and the 4 surfaces,
// deriv_plant_*), told apart by the presence of the first reference column.
struct DerivativeTable {
  bool closed_loop = false;
  std::size_t n_inputs = 0;           // the leading columns copied from the input
  std::vector<std::string> header;    // inputs, then every value the model probe names
  std::vector<std::vector<double>> rows;
  std::vector<std::string> cases;     // the input's `case` column, empty when it has none
};
DerivativeTable evaluate_derivatives(const io::CsvTable& points, dynamics::AeroModel model);

// Largest difference per column between our rows and the same-named column of `theirs`, from
// column `first_column` of `header` on (columns `theirs` lacks are skipped). Relative:
// |ours - theirs| / max(1, |theirs|). A NaN difference is the worst.
struct ColumnDiff {
  std::string column;
  double worst = 0.0;
  std::size_t at_row = 0;
};
std::vector<ColumnDiff> compare_columns(const io::CsvTable& theirs, const std::vector<std::string>& header,
                                        const std::vector<std::vector<double>>& rows, std::size_t first_column,
                                        bool relative);

// rows[r][c] under `header` (and string columns after them), written atomically.
void write_rows(const std::string& path, const std::vector<std::string>& header,
                const std::vector<std::vector<double>>& rows, const std::vector<std::string>& string_header = {},
                const std::vector<std::vector<std::string>>& string_columns = {});

}  // namespace f16race::aerobench_files
