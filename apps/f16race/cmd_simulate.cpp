// `f16race simulate`: fly one F-16 against recorded or scripted outer-loop references, or
// evaluate the model's derivatives at given points, and compare with AeroBench's own numbers.
#include <CLI/CLI.hpp>
#include <algorithm>
#include <cmath>
#include <cstdio>
#include <string>
#include <vector>

#include "commands.hpp"
#include "dynamics/model_probe.hpp"
#include "dynamics/reference_replay.hpp"
#include "dynamics/trim.hpp"
#include "io/csv_table.hpp"

namespace f16race::app {
namespace {

using namespace f16race::dynamics;

struct SimulateOptions {
  std::string model = "morelli";
  std::string integrator = "rk4";
  std::string interp = "hold";
  std::string reference;
  std::string derivatives;
  std::string commands;
  std::string out;
  double dt_s = 0.01;
  double trim_vt_ftps = 540.0;
  double trim_alt_ft = 5000.0;
  double duration_s = 15.0;
  double sample_s = 0.02;
  bool compare = false;
};

AeroModel parse_model(const std::string& text) {
  AeroModel m;
  if (!parse_aero_model(text.c_str(), &m)) throw UserError("--model '" + text + "': use morelli or stevens");
  return m;
}

// Header of trajectory files, identical to the AeroBench reference CSVs minus `mode`.
std::vector<std::string> trajectory_header() {
  std::vector<std::string> h{"t_s"};
  for (const char* n : kStateNames) h.push_back(n);
  for (const char* n : {"Nz_g", "ps_radps", "Ny_r_mixed", "Ny_g"}) h.push_back(n);
  for (const char* n : kRefNames) h.push_back(n);
  for (const char* n : kSurfaceNames) h.push_back(n);
  for (const char* n : kStateDerivativeNames) h.push_back(n);
  return h;
}

std::vector<double> sample_row(const ReplaySample& s) {
  std::vector<double> row{s.t_s};
  row.insert(row.end(), s.x.begin(), s.x.end());
  row.insert(row.end(), {s.nz_g, s.ps_radps, s.ny_r, s.ny_g});
  row.insert(row.end(), s.u_ref.begin(), s.u_ref.end());
  row.insert(row.end(), {s.throttle, s.elevator_deg, s.aileron_deg, s.rudder_deg});
  row.insert(row.end(), s.xdot.begin(), s.xdot.end());
  return row;
}

void write_rows(const std::string& path, const std::vector<std::string>& header,
                const std::vector<std::vector<double>>& rows, const std::vector<std::string>& string_header = {},
                const std::vector<std::vector<std::string>>& string_columns = {}) {
  std::vector<std::vector<double>> cols(header.size(), std::vector<double>(rows.size()));
  for (std::size_t r = 0; r < rows.size(); ++r)
    for (std::size_t c = 0; c < header.size(); ++c) cols[c][r] = rows[r][c];
  io::write_csv(path, header, cols, string_header, string_columns);
}

std::vector<double> require_column(const io::CsvTable& t, const std::string& name) {
  if (!t.has_column(name))
    throw UserError(t.source() + ": missing column '" + name + "' (the AeroBench reference format names it so)");
  return t.numeric(name);
}

// Largest |ours - theirs| per column of `header` present in both, printed as a table.
void print_comparison(const io::CsvTable& ref, const std::vector<std::string>& header,
                      const std::vector<std::vector<double>>& rows, bool relative) {
  std::printf("%-22s %14s %12s\n", "column", relative ? "max_rel_diff" : "max_abs_diff", "at_row");
  for (std::size_t c = 1; c < header.size(); ++c) {
    if (!ref.has_column(header[c])) continue;
    const std::vector<double> theirs = ref.numeric(header[c]);
    double worst = 0.0;
    std::size_t at = 0;
    for (std::size_t r = 0; r < rows.size() && r < theirs.size(); ++r) {
      double d = std::fabs(rows[r][c] - theirs[r]);
      if (relative) d /= std::max(1.0, std::fabs(theirs[r]));
      if (!(d <= worst)) {  // also catches NaN
        worst = d;
        at = r;
      }
    }
    std::printf("%-22s %14.3e %12zu\n", header[c].c_str(), worst, at);
  }
}

void run_trajectory(const SimulateOptions& o) {
  const AeroModel model = parse_model(o.model);
  ReplayRequest req;
  req.model = model;
  if (!parse_integrator(o.integrator.c_str(), &req.integrator))
    throw UserError("--integrator '" + o.integrator + "': use rk4 or euler");
  if (o.interp == "hold") req.refs.interp = RefInterp::kHold;
  else if (o.interp == "linear") req.refs.interp = RefInterp::kLinear;
  else throw UserError("--interp '" + o.interp + "': use hold or linear");
  req.dt_s = o.dt_s;

  io::CsvTable ref_table = io::CsvTable::parse("t_s\n0\n", "(none)");
  if (!o.reference.empty()) {
    ref_table = io::CsvTable::read(o.reference);
    req.output_times_s = require_column(ref_table, "t_s");
    if (req.output_times_s.empty()) throw UserError(o.reference + ": no data rows");
    for (int s = 0; s < kNumStates; ++s) req.x0[s] = require_column(ref_table, kStateNames[s]).front();
    req.refs.t_s = req.output_times_s;
    for (int r = 0; r < kNumRefs; ++r) req.refs.values[r] = require_column(ref_table, kRefNames[r]);
    // An autopilot's `mode` column marks where references jump: never interpolate across it.
    if (ref_table.has_column("mode")) {
      const std::size_t c = ref_table.column_index("mode");
      for (std::size_t k = 0; k < ref_table.rows(); ++k) {
        const bool changed = k > 0 && ref_table.cell(k, c) != ref_table.cell(k - 1, c);
        req.refs.segment.push_back(k == 0 ? 0 : req.refs.segment.back() + (changed ? 1 : 0));
      }
    }
  } else {
    // Scripted: trim, then the command file's columns are offsets added to the trim references.
    TrimRequest trim_req;
    trim_req.model = model;
    trim_req.vt_ftps = o.trim_vt_ftps;
    trim_req.alt_ft = o.trim_alt_ft;
    TrimResult trim;
    try {
      trim = trim_level_flight(trim_req);
    } catch (const std::runtime_error& e) {
      throw UserError(e.what());
    }
    req.x0 = trim.x0;
    if (!(o.duration_s > 0.0) || !(o.sample_s > 0.0)) throw UserError("--duration and --sample must be > 0");
    // Checked before the cast: a huge ratio would overflow int and simulate nothing.
    constexpr double kMaxSamples = 1e7;
    if (o.duration_s / o.sample_s > kMaxSamples)
      throw UserError("--duration " + std::to_string(o.duration_s) + " s at --sample " + std::to_string(o.sample_s) +
                      " s would write more than 10 000 000 samples; shorten --duration or raise --sample");
    const int n = static_cast<int>(std::floor(o.duration_s / o.sample_s + 1e-9));
    for (int k = 0; k <= n; ++k) req.output_times_s.push_back(k * o.sample_s);
    if (!o.commands.empty()) {
      const io::CsvTable cmd = io::CsvTable::read(o.commands);
      req.refs.t_s = require_column(cmd, "t_s");
      // No rows would fly every reference at 0 instead of the trim values.
      if (req.refs.t_s.empty())
        throw UserError(o.commands + ": has a header but no rows; give at least one row (t_s = 0 and the deltas "
                                     "from trim), or leave out --commands to fly at trim");
      for (std::size_t j = 1; j < req.refs.t_s.size(); ++j)
        if (!(req.refs.t_s[j] > req.refs.t_s[j - 1]))
          throw UserError(o.commands + ": t_s must increase strictly (line " + std::to_string(j + 2) + ")");
      bool any = false;
      for (int r = 0; r < kNumRefs; ++r) {
        std::vector<double> v(req.refs.t_s.size(), 0.0);
        if (cmd.has_column(kRefNames[r])) {
          v = cmd.numeric(kRefNames[r]);
          any = true;
        }
        for (double& x : v) x += trim.u_ref[r];
        req.refs.values[r] = v;
      }
      if (!any)
        throw UserError(o.commands + ": needs t_s and at least one of Nz_ref_g, ps_ref_radps, Ny_r_ref_mixed, "
                                     "throttle_ref_delta");
    } else {
      req.refs.t_s = {0.0};
      for (int r = 0; r < kNumRefs; ++r) req.refs.values[r] = {trim.u_ref[r]};
    }
  }
  for (std::size_t j = 1; j < req.output_times_s.size(); ++j)
    if (!(req.output_times_s[j] > req.output_times_s[j - 1]))
      throw UserError(o.reference + ": t_s must increase strictly (line " + std::to_string(j + 2) + ")");

  const ReplayResult result = replay_references(req);
  std::vector<std::vector<double>> rows;
  rows.reserve(result.samples.size());
  for (const ReplaySample& s : result.samples) rows.push_back(sample_row(s));
  const std::vector<std::string> header = trajectory_header();
  write_rows(o.out, header, rows);
  if (result.status != kStatusOk) {
    char buf[256];
    std::snprintf(buf, sizeof buf,
                  "the aircraft left the model's envelope (%s) at t=%.4f s; %zu rows up to then written to %s",
                  status_name(result.status), result.failed_at_s, rows.size(), o.out.c_str());
    throw UserError(buf);
  }
  std::printf("simulated %zu samples (%s, %s, dt %.4g s) -> %s\n", rows.size(), aero_model_name(model),
              integrator_name(req.integrator), req.dt_s, o.out.c_str());
  if (o.compare) {
    if (o.reference.empty()) throw UserError("--compare needs --reference");
    print_comparison(ref_table, header, rows, /*relative=*/false);
  }
}

void run_derivatives(const SimulateOptions& o) {
  const AeroModel model = parse_model(o.model);
  const io::CsvTable in = io::CsvTable::read(o.derivatives);
  const bool closed_loop = in.has_column(kRefNames[0]);
  const std::size_t n = in.rows();
  std::vector<std::vector<double>> inputs;
  std::vector<std::string> header;
  const int n_in_states = closed_loop ? kNumStates : kNumPlantStates;
  for (int s = 0; s < n_in_states; ++s) {
    inputs.push_back(require_column(in, kStateNames[s]));
    header.push_back(kStateNames[s]);
  }
  const std::vector<std::string> extra = closed_loop
      ? std::vector<std::string>(kRefNames.begin(), kRefNames.end())
      : std::vector<std::string>{"throttle", "elevator_deg", "aileron_deg", "rudder_deg"};
  for (const std::string& name : extra) {
    inputs.push_back(require_column(in, name));
    header.push_back(name);
  }
  std::vector<std::vector<double>> rows(n);
  for (std::size_t r = 0; r < n; ++r) {
    std::vector<NamedValue> values;
    if (closed_loop) {
      StateVector x;
      RefVector u;
      for (int s = 0; s < kNumStates; ++s) x[s] = inputs[s][r];
      for (int k = 0; k < kNumRefs; ++k) u[k] = inputs[kNumStates + k][r];
      values = probe_closed_loop(model, x, u);
    } else {
      double x[kNumPlantStates];
      for (int s = 0; s < kNumPlantStates; ++s) x[s] = inputs[s][r];
      const SurfaceCommands u{inputs[13][r], inputs[14][r], inputs[15][r], inputs[16][r]};
      values = probe_plant(model, x, u);
    }
    if (r == 0)
      for (const NamedValue& v : values) header.push_back(v.name);
    for (std::size_t c = 0; c < inputs.size(); ++c) rows[r].push_back(inputs[c][r]);
    for (const NamedValue& v : values) rows[r].push_back(v.value);
  }
  std::vector<std::string> string_header;
  std::vector<std::vector<std::string>> string_columns;
  if (in.has_column("case")) {
    string_header.push_back("case");
    std::vector<std::string> cases;
    const std::size_t c = in.column_index("case");
    for (std::size_t r = 0; r < n; ++r) cases.push_back(in.cell(r, c));
    string_columns.push_back(cases);
  }
  // write_rows wants a leading column it can skip in comparisons; derivatives have none.
  write_rows(o.out, header, rows, string_header, string_columns);
  std::printf("evaluated %zu %s points (%s) -> %s\n", n, closed_loop ? "closed-loop" : "plant", aero_model_name(model),
              o.out.c_str());
  if (o.compare) {
    std::vector<std::string> h{"(row)"};
    std::vector<std::vector<double>> shifted(n);
    for (std::size_t r = 0; r < n; ++r) {
      shifted[r].push_back(0.0);
      shifted[r].insert(shifted[r].end(), rows[r].begin() + static_cast<long>(inputs.size()), rows[r].end());
    }
    h.insert(h.end(), header.begin() + static_cast<long>(inputs.size()), header.end());
    print_comparison(in, h, shifted, /*relative=*/true);
  }
}

}  // namespace

void add_simulate_command(CLI::App& app) {
  auto opts = std::make_shared<SimulateOptions>();
  CLI::App* cmd = app.add_subcommand(
      "simulate",
      "Fly one F-16 against a reference/command time series, or evaluate derivatives at given points");
  cmd->add_option("--model", opts->model, "Aerodynamic model: morelli (default) or stevens");
  cmd->add_option("--reference", opts->reference,
                  "Trajectory CSV in AeroBench reference format: start state from row 1, references "
                  "from Nz_ref_g, ps_ref_radps, Ny_r_ref_mixed, throttle_ref_delta, outputs at its t_s");
  cmd->add_option("--derivatives", opts->derivatives,
                  "Points CSV in deriv_plant_* / deriv_closed_loop_* format: evaluate the model at each row");
  cmd->add_option("--commands", opts->commands,
                  "Scripted run: CSV with t_s and any reference columns, as offsets from the trim references");
  cmd->add_option("--trim-vt", opts->trim_vt_ftps, "Scripted run: trim airspeed [ft/s]")->check(CLI::PositiveNumber);
  cmd->add_option("--trim-alt", opts->trim_alt_ft, "Scripted run: trim altitude [ft]");
  cmd->add_option("--duration", opts->duration_s, "Scripted run: length [s]")->check(CLI::PositiveNumber);
  cmd->add_option("--sample", opts->sample_s, "Scripted run: output interval [s]")->check(CLI::PositiveNumber);
  cmd->add_option("--dt", opts->dt_s, "Largest integration step [s]")->check(CLI::Range(1e-6, 1.0));
  cmd->add_option("--integrator", opts->integrator, "rk4 (default) or euler");
  cmd->add_option("--interp", opts->interp, "Reference interpolation: hold (default, step inputs) or linear (smooth inputs); never across a change of the file's `mode` column");
  cmd->add_option("--out", opts->out, "Output CSV (same columns as the input format)")->required();
  cmd->add_flag("--compare", opts->compare, "Print the largest difference to the input file per column");
  cmd->callback([opts]() {
    if (!opts->derivatives.empty()) {
      if (!opts->reference.empty() || !opts->commands.empty())
        throw UserError("--derivatives cannot be combined with --reference or --commands");
      run_derivatives(*opts);
    } else {
      if (!opts->reference.empty() && !opts->commands.empty())
        throw UserError("give either --reference or --commands, not both");
      run_trajectory(*opts);
    }
  });
}

}  // namespace f16race::app
