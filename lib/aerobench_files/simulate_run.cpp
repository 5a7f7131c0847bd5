#include "aerobench_files/simulate_run.hpp"

#include <algorithm>
#include <chrono>
#include <cstdio>
#include <memory>
#include <optional>

#include "dynamics/autopilot_batch.hpp"
#include "dynamics/gcas_autopilot.hpp"
#include "dynamics/reference_replay.hpp"
#include "dynamics/waypoint_autopilot.hpp"
#include "io/csv_table.hpp"
#include "io/input_error.hpp"

namespace f16race::aerobench_files {
namespace {

using namespace f16race::dynamics;

// AeroBench samples its autopilot runs at 30 Hz.
double autopilot_sample_s(const SimulateRequest& o) { return o.sample_given ? o.sample_s : 1.0 / 30.0; }

// The outer loop named by --autopilot; its initial mode from `mode_text` (a file's first `mode`
// cell; GCAS only) when given.
std::unique_ptr<OuterLoop> make_autopilot(const SimulateRequest& o, const std::string& mode_text) {
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
    return std::make_unique<WaypointAutopilot>(read_waypoints(io::CsvTable::read(o.waypoints)));
  }
  throw io::InputError("--autopilot '" + o.autopilot + "': use gcas or waypoint");
}

AeroModel parse_model(const std::string& text) {
  AeroModel m;
  if (!parse_aero_model(text.c_str(), &m)) throw io::InputError("--model '" + text + "': use morelli or stevens");
  return m;
}

ReplaySettings replay_settings(const SimulateRequest& o) {
  ReplaySettings s;
  s.model = parse_model(o.model);
  if (!parse_integrator(o.integrator.c_str(), &s.integrator))
    throw io::InputError("--integrator '" + o.integrator + "': use rk4 or euler");
  if (o.interp == "hold") s.interp = RefInterp::kHold;
  else if (o.interp == "linear") s.interp = RefInterp::kLinear;
  else throw io::InputError("--interp '" + o.interp + "': use hold or linear");
  s.dt_s = o.dt_s;
  return s;
}

// The batch's law and its per-aircraft start modes or shared waypoints, from the options and
// the start file's `mode` cells.
void set_batch_law(const SimulateRequest& o, const io::CsvTable& init, AutopilotBatchRequest* req) {
  const std::vector<std::string> modes = row_modes(init);
  if (o.autopilot == "gcas") {
    if (!o.waypoints.empty()) throw io::InputError("--waypoints is for --autopilot waypoint, not gcas");
    req->law = StageLaw::kGcas;
    for (std::size_t k = 0; k < modes.size(); ++k) {
      GcasMode m = GcasMode::kStandby;
      if (!modes[k].empty() && !parse_gcas_mode(modes[k], &m))
        throw io::InputError(init.source() + ": row " + std::to_string(k + 1) + "'s mode '" + modes[k] +
                             "' is not a GCAS mode: use standby, roll, pull or waiting");
      req->gcas_modes.push_back(m);
    }
  } else if (o.autopilot == "waypoint") {
    if (o.waypoints.empty()) throw io::InputError("--autopilot waypoint needs --waypoints FILE (columns e_ft, n_ft, alt_ft)");
    req->law = StageLaw::kWaypoint;
    req->waypoints = {read_waypoints(io::CsvTable::read(o.waypoints))};
  } else {
    throw io::InputError("--autopilot '" + o.autopilot + "': use gcas or waypoint");
  }
}

// One summary row per aircraft to o.out, and the counts over them.
void write_batch_rows(const std::string& out, const AutopilotBatchResult& res, BatchOutcome* summary) {
  std::vector<std::string> header{"aircraft", "failed_at_s", "finished_at_s", "samples", "min_alt_ft", "min_alt_t_s"};
  for (const char* n : kStateNames) header.push_back(n);
  std::vector<std::vector<double>> rows;
  std::vector<std::string> status_col, mode_col;
  for (std::size_t i = 0; i < res.aircraft.size(); ++i) {
    const AutopilotAircraftResult& a = res.aircraft[i];
    std::vector<double> row{static_cast<double>(i), a.status == kStatusOk ? -1.0 : a.failed_at_s,
                            a.finished ? a.finished_at_s : -1.0, static_cast<double>(a.samples), a.min_alt_ft,
                            a.min_alt_t_s};
    row.insert(row.end(), a.x_last.begin(), a.x_last.end());
    rows.push_back(std::move(row));
    status_col.push_back(status_name(a.status));
    mode_col.push_back(a.mode);
    summary->failed += a.status != kStatusOk;
    summary->finished += a.finished;
    summary->below_ground += a.min_alt_ft < 0.0;
    summary->lowest_alt_ft = i == 0 ? a.min_alt_ft : std::min(summary->lowest_alt_ft, a.min_alt_ft);
  }
  write_rows(out, header, rows, {"status", "mode"}, {status_col, mode_col});
}

// `--autopilot ... --init FILE` with more than one row: every row its own aircraft, all flown
// together by F16Batch with the law at every RK stage.
BatchOutcome run_autopilot_batch(const SimulateRequest& o, const io::CsvTable& init, const ReplaySettings& settings) {
  if (o.compare) throw io::InputError("--compare needs --reference (a batch from --init has nothing to compare with)");
  AutopilotBatchRequest req;
  req.model = settings.model;
  req.integrator = settings.integrator;
  req.dt_s = settings.dt_s;
  req.x0 = initial_states(init);
  req.output_times_s = sample_times(o.duration_s, autopilot_sample_s(o));
  set_batch_law(o, init, &req);
  const auto t0 = std::chrono::steady_clock::now();
  const AutopilotBatchResult res = fly_autopilot_batch(req);
  BatchOutcome b;
  b.wall_s = std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
  write_batch_rows(o.out, res, &b);
  b.aircraft = res.aircraft.size();
  b.duration_s = req.output_times_s.back();
  b.model = req.model;
  b.integrator = req.integrator;
  b.dt_s = req.dt_s;
  return b;
}

// Writes the trajectory (with AeroBench's mode column for an autopilot run); an aircraft that
// left the envelope is an error once its rows up to then are written.
void write_trajectory(const std::string& out, const ReplayResult& result, bool with_modes,
                      const std::vector<std::vector<double>>& rows) {
  const std::vector<std::string> header = trajectory_header();
  if (with_modes) {
    std::vector<std::string> modes;
    for (const ReplaySample& s : result.samples) modes.push_back(s.mode);
    write_rows(out, header, rows, {"mode"}, {modes});
  } else {
    write_rows(out, header, rows);
  }
  if (result.status != kStatusOk) {
    char buf[256];
    std::snprintf(buf, sizeof buf,
                  "the aircraft left the model's envelope (%s) at t=%.4f s; %zu rows up to then written to %s",
                  status_name(result.status), result.failed_at_s, rows.size(), out.c_str());
    throw io::InputError(buf);
  }
}

}  // namespace

void check_sources(const SimulateRequest& o) {
  if (!o.derivatives.empty()) {
    if (!o.reference.empty() || !o.commands.empty())
      throw io::InputError("--derivatives cannot be combined with --reference or --commands");
    return;
  }
  if (!o.reference.empty() && !o.commands.empty()) throw io::InputError("give either --reference or --commands, not both");
  if (!o.autopilot.empty() && !o.commands.empty())
    throw io::InputError("--autopilot sets the references itself: leave out --commands");
  if (!o.init.empty() && !o.reference.empty())
    throw io::InputError("--init and --reference both give a start state: use one");
}

SimulateOutcome simulate_to_file(const SimulateRequest& o) {
  const ReplaySettings settings = replay_settings(o);
  ReplayRequest req;
  std::optional<io::CsvTable> ref_table;
  std::unique_ptr<OuterLoop> autopilot;
  SimulateOutcome outcome;
  if (!o.reference.empty()) {
    ref_table = io::CsvTable::read(o.reference);
    req = request_from_reference(*ref_table, settings);
    // The reference gives the start state and the sample times; the autopilot its references.
    if (!o.autopilot.empty()) autopilot = make_autopilot(o, initial_mode(*ref_table));
  } else if (!o.autopilot.empty()) {
    if (o.init.empty()) throw io::InputError("--autopilot without --reference needs --init FILE (the start state)");
    const io::CsvTable init = io::CsvTable::read(o.init);
    if (init.rows() > 1) {
      outcome.is_batch = true;
      outcome.batch = run_autopilot_batch(o, init, settings);
      return outcome;
    }
    req = request_from_initial_state(init, o.duration_s, autopilot_sample_s(o), settings);
    autopilot = make_autopilot(o, initial_mode(init));
  } else {
    std::optional<io::CsvTable> commands;
    if (!o.commands.empty()) commands = io::CsvTable::read(o.commands);
    const ScriptedRun run{o.trim_vt_ftps, o.trim_alt_ft, o.duration_s, o.sample_s};
    req = request_from_commands(commands ? &*commands : nullptr, run, settings);
  }
  req.autopilot = autopilot.get();
  const ReplayResult result = replay_references(req);
  const std::vector<std::vector<double>> rows = trajectory_rows(result);
  write_trajectory(o.out, result, autopilot != nullptr, rows);
  TrajectoryOutcome& t = outcome.trajectory;
  t.samples = rows.size();
  t.model = settings.model;
  t.integrator = req.integrator;
  t.dt_s = req.dt_s;
  t.autopilot = autopilot != nullptr;
  t.autopilot_finished = result.autopilot_finished;
  t.has_reference = ref_table.has_value();
  if (o.compare && ref_table)
    t.comparison = compare_columns(*ref_table, trajectory_header(), rows, 1, /*relative=*/false);
  return outcome;
}

DerivativesOutcome derivatives_to_file(const SimulateRequest& o) {
  DerivativesOutcome r;
  r.model = parse_model(o.model);
  const io::CsvTable in = io::CsvTable::read(o.derivatives);
  const DerivativeTable d = evaluate_derivatives(in, r.model);
  std::vector<std::string> string_header;
  std::vector<std::vector<std::string>> string_columns;
  if (!d.cases.empty()) {
    string_header.push_back("case");
    string_columns.push_back(d.cases);
  }
  write_rows(o.out, d.header, d.rows, string_header, string_columns);
  r.points = d.rows.size();
  r.closed_loop = d.closed_loop;
  // Only the model's values are compared: the inputs are the file's own.
  if (o.compare) r.comparison = compare_columns(in, d.header, d.rows, d.n_inputs, /*relative=*/true);
  return r;
}

}  // namespace f16race::aerobench_files
