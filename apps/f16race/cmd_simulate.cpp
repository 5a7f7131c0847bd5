// `f16race simulate`: fly one F-16 against recorded or scripted outer-loop references, or
// evaluate the model's derivatives at given points, and compare with AeroBench's own numbers.
#include <CLI/CLI.hpp>
#include <chrono>
#include <cstdlib>
#include <cstdio>
#include <memory>
#include <optional>
#include <string>
#include <vector>

#include "aerobench_files/aerobench_csv.hpp"
#include "commands.hpp"
#include "dynamics/autopilot_batch.hpp"
#include "dynamics/gcas_autopilot.hpp"
#include "dynamics/reference_replay.hpp"
#include "dynamics/waypoint_autopilot.hpp"
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

// The outer loop named by --autopilot; its initial mode from `mode_text` (a file's first `mode`
// cell; GCAS only) when given.
std::unique_ptr<OuterLoop> make_autopilot(const SimulateOptions& o, const std::string& mode_text) {
  if (o.autopilot == "gcas") {
    if (!o.waypoints.empty()) throw io::InputError("--waypoints is for --autopilot waypoint, not gcas");
    GcasMode mode = GcasMode::kStandby;
    if (!mode_text.empty() && !parse_gcas_mode(mode_text, &mode))
      throw io::InputError("the start mode '" + mode_text + "' (first row's `mode`) is not a GCAS mode: use standby, "
                           "roll, pull or waiting");
    return std::make_unique<GcasAutopilot>(mode);
  }
  if (o.autopilot == "waypoint") {
    if (o.waypoints.empty()) throw io::InputError("--autopilot waypoint needs --waypoints FILE (columns e_ft, n_ft, alt_ft)");
    return std::make_unique<WaypointAutopilot>(aerobench_files::read_waypoints(io::CsvTable::read(o.waypoints)));
  }
  throw io::InputError("--autopilot '" + o.autopilot + "': use gcas or waypoint");
}

AeroModel parse_model(const std::string& text) {
  AeroModel m;
  if (!parse_aero_model(text.c_str(), &m)) throw io::InputError("--model '" + text + "': use morelli or stevens");
  return m;
}

void print_comparison(const std::vector<aerobench_files::ColumnDiff>& diffs, bool relative) {
  std::printf("%-22s %14s %12s\n", "column", relative ? "max_rel_diff" : "max_abs_diff", "at_row");
  for (const auto& d : diffs) std::printf("%-22s %14.3e %12zu\n", d.column.c_str(), d.worst, d.at_row);
}

aerobench_files::ReplaySettings replay_settings(const SimulateOptions& o) {
  aerobench_files::ReplaySettings s;
  s.model = parse_model(o.model);
  if (!parse_integrator(o.integrator.c_str(), &s.integrator))
    throw io::InputError("--integrator '" + o.integrator + "': use rk4 or euler");
  if (o.interp == "hold") s.interp = RefInterp::kHold;
  else if (o.interp == "linear") s.interp = RefInterp::kLinear;
  else throw io::InputError("--interp '" + o.interp + "': use hold or linear");
  s.dt_s = o.dt_s;
  return s;
}

// `--autopilot ... --init FILE` with more than one row: every row its own aircraft, all flown
// together by F16Batch with the law at every RK stage; one summary row per aircraft.
void run_autopilot_batch(const SimulateOptions& o, const io::CsvTable& init,
                         const aerobench_files::ReplaySettings& settings) {
  if (o.compare) throw io::InputError("--compare needs --reference (a batch from --init has nothing to compare with)");
  AutopilotBatchRequest req;
  req.model = settings.model;
  req.integrator = settings.integrator;
  req.dt_s = settings.dt_s;
  req.x0 = aerobench_files::initial_states(init);
  req.output_times_s = aerobench_files::sample_times(o.duration_s, o.sample_given ? o.sample_s : 1.0 / 30.0);
  const std::vector<std::string> modes = aerobench_files::row_modes(init);
  if (o.autopilot == "gcas") {
    if (!o.waypoints.empty()) throw io::InputError("--waypoints is for --autopilot waypoint, not gcas");
    req.law = StageLaw::kGcas;
    for (std::size_t k = 0; k < modes.size(); ++k) {
      GcasMode m = GcasMode::kStandby;
      if (!modes[k].empty() && !parse_gcas_mode(modes[k], &m))
        throw io::InputError(init.source() + ": row " + std::to_string(k + 1) + "'s mode '" + modes[k] +
                             "' is not a GCAS mode: use standby, roll, pull or waiting");
      req.gcas_modes.push_back(m);
    }
  } else if (o.autopilot == "waypoint") {
    if (o.waypoints.empty()) throw io::InputError("--autopilot waypoint needs --waypoints FILE (columns e_ft, n_ft, alt_ft)");
    req.law = StageLaw::kWaypoint;
    req.waypoints = {aerobench_files::read_waypoints(io::CsvTable::read(o.waypoints))};
  } else {
    throw io::InputError("--autopilot '" + o.autopilot + "': use gcas or waypoint");
  }
  const auto t0 = std::chrono::steady_clock::now();
  const AutopilotBatchResult res = fly_autopilot_batch(req);
  const double wall_s = std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();

  std::vector<std::string> header{"aircraft", "failed_at_s", "finished_at_s", "samples", "min_alt_ft", "min_alt_t_s"};
  for (const char* n : kStateNames) header.push_back(n);
  std::vector<std::vector<double>> rows;
  std::vector<std::string> status_col, mode_col;
  int failed = 0, finished = 0, below_ground = 0;
  double lowest = 0.0;
  for (std::size_t i = 0; i < res.aircraft.size(); ++i) {
    const AutopilotAircraftResult& a = res.aircraft[i];
    std::vector<double> row{static_cast<double>(i), a.status == kStatusOk ? -1.0 : a.failed_at_s,
                            a.finished ? a.finished_at_s : -1.0, static_cast<double>(a.samples), a.min_alt_ft,
                            a.min_alt_t_s};
    row.insert(row.end(), a.x_last.begin(), a.x_last.end());
    rows.push_back(std::move(row));
    status_col.push_back(status_name(a.status));
    mode_col.push_back(a.mode);
    failed += a.status != kStatusOk;
    finished += a.finished;
    below_ground += a.min_alt_ft < 0.0;
    lowest = i == 0 ? a.min_alt_ft : std::min(lowest, a.min_alt_ft);
  }
  aerobench_files::write_rows(o.out, header, rows, {"status", "mode"}, {status_col, mode_col});
  std::printf("flew %zu aircraft for %.4g s (%s, %s, dt %.4g s, autopilot %s at every RK stage) in %.2f s: %d left "
              "the envelope, %d finished, %d below 0 ft at a sample (lowest %.1f ft) -> %s (one row per aircraft; "
              "failed_at_s and finished_at_s -1 when not)\n",
              res.aircraft.size(), req.output_times_s.back(), aero_model_name(req.model),
              integrator_name(req.integrator), req.dt_s, o.autopilot.c_str(), wall_s, failed, finished, below_ground,
              lowest, o.out.c_str());
}

void run_trajectory(const SimulateOptions& o) {
  const aerobench_files::ReplaySettings settings = replay_settings(o);
  ReplayRequest req;
  std::optional<io::CsvTable> ref_table;
  std::unique_ptr<OuterLoop> autopilot;
  if (!o.reference.empty()) {
    ref_table = io::CsvTable::read(o.reference);
    req = aerobench_files::request_from_reference(*ref_table, settings);
    // The reference gives the start state and the sample times; the autopilot its references.
    if (!o.autopilot.empty()) autopilot = make_autopilot(o, aerobench_files::initial_mode(*ref_table));
  } else if (!o.autopilot.empty()) {
    if (o.init.empty()) throw io::InputError("--autopilot without --reference needs --init FILE (the start state)");
    const io::CsvTable init = io::CsvTable::read(o.init);
    if (init.rows() > 1) return run_autopilot_batch(o, init, settings);
    // AeroBench samples its autopilot runs at 30 Hz.
    req = aerobench_files::request_from_initial_state(init, o.duration_s, o.sample_given ? o.sample_s : 1.0 / 30.0,
                                                      settings);
    autopilot = make_autopilot(o, aerobench_files::initial_mode(init));
  } else {
    std::optional<io::CsvTable> commands;
    if (!o.commands.empty()) commands = io::CsvTable::read(o.commands);
    const aerobench_files::ScriptedRun run{o.trim_vt_ftps, o.trim_alt_ft, o.duration_s, o.sample_s};
    req = aerobench_files::request_from_commands(commands ? &*commands : nullptr, run, settings);
  }
  req.autopilot = autopilot.get();
  const ReplayResult result = replay_references(req);
  const std::vector<std::vector<double>> rows = aerobench_files::trajectory_rows(result);
  const std::vector<std::string> header = aerobench_files::trajectory_header();
  if (autopilot) {  // the mode column, as in AeroBench's runs
    std::vector<std::string> modes;
    for (const ReplaySample& s : result.samples) modes.push_back(s.mode);
    aerobench_files::write_rows(o.out, header, rows, {"mode"}, {modes});
  } else {
    aerobench_files::write_rows(o.out, header, rows);
  }
  if (result.status != kStatusOk) {
    char buf[256];
    std::snprintf(buf, sizeof buf,
                  "the aircraft left the model's envelope (%s) at t=%.4f s; %zu rows up to then written to %s",
                  status_name(result.status), result.failed_at_s, rows.size(), o.out.c_str());
    throw io::InputError(buf);
  }
  std::printf("simulated %zu samples (%s, %s, dt %.4g s%s%s) -> %s\n", rows.size(), aero_model_name(settings.model),
              integrator_name(req.integrator), req.dt_s, autopilot ? ", autopilot " : "",
              autopilot ? (o.autopilot + (result.autopilot_finished ? ", finished" : "")).c_str() : "", o.out.c_str());
  if (o.compare) {
    if (!ref_table) throw io::InputError("--compare needs --reference");
    print_comparison(aerobench_files::compare_columns(*ref_table, header, rows, 1, /*relative=*/false), false);
  }
}

void run_derivatives(const SimulateOptions& o) {
  const AeroModel model = parse_model(o.model);
  const io::CsvTable in = io::CsvTable::read(o.derivatives);
  const aerobench_files::DerivativeTable d = aerobench_files::evaluate_derivatives(in, model);
  std::vector<std::string> string_header;
  std::vector<std::vector<std::string>> string_columns;
  if (!d.cases.empty()) {
    string_header.push_back("case");
    string_columns.push_back(d.cases);
  }
  aerobench_files::write_rows(o.out, d.header, d.rows, string_header, string_columns);
  std::printf("evaluated %zu %s points (%s) -> %s\n", d.rows.size(), d.closed_loop ? "closed-loop" : "plant",
              aero_model_name(model), o.out.c_str());
  // Only the model's values are compared: the inputs are the file's own.
  if (o.compare) print_comparison(aerobench_files::compare_columns(in, d.header, d.rows, d.n_inputs, /*relative=*/true), true);
}

// > 0, said in a short line (CLI::PositiveNumber's message prints DBL_MAX's 309 digits); nan and
// inf are refused for every option in main.
const CLI::Validator kPositive(
    [](std::string& text) {
      char* end = nullptr;
      const double v = std::strtod(text.c_str(), &end);
      if (end == text.c_str() || *end != '\0') return std::string();  // not a number: the conversion says so
      return v > 0.0 ? std::string() : "'" + text + "' must be > 0";
    },
    "POSITIVE");

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
  cmd->add_option("--autopilot", opts->autopilot,
                  "Fly AeroBench's outer loop natively, evaluated at every RK stage: gcas or waypoint. With "
                  "--reference: its start state, start mode and sample times; without: --init and --duration");
  cmd->add_option("--waypoints", opts->waypoints, "--autopilot waypoint: CSV with e_ft, n_ft, alt_ft, one waypoint a row");
  cmd->add_option("--init", opts->init,
                  "--autopilot without --reference: CSV of start states (reference-format state columns; "
                  "integrators optional; optional start `mode`). One row: its trajectory. Several: every row an "
                  "aircraft, flown as one batch; --out gets one summary row per aircraft");
  cmd->add_option("--trim-vt", opts->trim_vt_ftps, "Scripted run: trim airspeed [ft/s]")->check(kPositive);
  cmd->add_option("--trim-alt", opts->trim_alt_ft, "Scripted run: trim altitude [ft]");
  cmd->add_option("--duration", opts->duration_s, "Scripted or autopilot run: length [s]")->check(kPositive);
  cmd->add_option("--sample", opts->sample_s, "Scripted or autopilot run: output interval [s] (default 0.02; autopilot 1/30)")
      ->check(kPositive)
      ->each([opts](const std::string&) { opts->sample_given = true; });
  cmd->add_option("--dt", opts->dt_s, "Largest integration step [s]")->check(CLI::Range(1e-6, 1.0));
  cmd->add_option("--integrator", opts->integrator, "rk4 (default) or euler");
  cmd->add_option("--interp", opts->interp, "Reference interpolation: hold (default, step inputs) or linear (smooth inputs); never across a change of the file's `mode` column");
  cmd->add_option("--out", opts->out, "Output CSV (same columns as the input format)")->required();
  cmd->add_flag("--compare", opts->compare, "Print the largest difference to the input file per column");
  cmd->callback([opts]() {
    if (!opts->derivatives.empty()) {
      if (!opts->reference.empty() || !opts->commands.empty())
        throw io::InputError("--derivatives cannot be combined with --reference or --commands");
      run_derivatives(*opts);
    } else {
      if (!opts->reference.empty() && !opts->commands.empty())
        throw io::InputError("give either --reference or --commands, not both");
      if (!opts->autopilot.empty() && !opts->commands.empty())
        throw io::InputError("--autopilot sets the references itself: leave out --commands");
      if (!opts->init.empty() && !opts->reference.empty())
        throw io::InputError("--init and --reference both give a start state: use one");
      run_trajectory(*opts);
    }
  });
}

}  // namespace f16race::app
