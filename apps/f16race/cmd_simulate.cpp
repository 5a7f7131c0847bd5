// `f16race simulate`: fly one F-16 against recorded or scripted outer-loop references, or
// evaluate the model's derivatives at given points, and compare with AeroBench's own numbers
// (aerobench_files::simulate_to_file and derivatives_to_file do it; this file parses and prints).
#include <CLI/CLI.hpp>
#include <cstdlib>
#include <cstdio>
#include <memory>
#include <string>
#include <vector>

#include "aerobench_files/simulate_run.hpp"
#include "commands.hpp"

namespace f16race::app {
namespace {

using namespace f16race::dynamics;
using aerobench_files::SimulateRequest;

void print_comparison(const std::vector<aerobench_files::ColumnDiff>& diffs, bool relative) {
  std::printf("%-22s %14s %12s\n", "column", relative ? "max_rel_diff" : "max_abs_diff", "at_row");
  for (const auto& d : diffs) std::printf("%-22s %14.3e %12zu\n", d.column.c_str(), d.worst, d.at_row);
}

void print_batch(const SimulateRequest& o, const aerobench_files::BatchOutcome& b) {
  std::printf("flew %zu aircraft for %.4g s (%s, %s, dt %.4g s, autopilot %s at every RK stage) in %.2f s: %d left "
              "the envelope, %d finished, %d below 0 ft at a sample (lowest %.1f ft) -> %s (one row per aircraft; "
              "failed_at_s and finished_at_s -1 when not)\n",
              b.aircraft, b.duration_s, aero_model_name(b.model), integrator_name(b.integrator), b.dt_s,
              o.autopilot.c_str(), b.wall_s, b.failed, b.finished, b.below_ground, b.lowest_alt_ft, o.out.c_str());
}

void run_trajectory(const SimulateRequest& o) {
  const aerobench_files::SimulateOutcome outcome = aerobench_files::simulate_to_file(o);
  if (outcome.is_batch) return print_batch(o, outcome.batch);
  const aerobench_files::TrajectoryOutcome& t = outcome.trajectory;
  std::printf("simulated %zu samples (%s, %s, dt %.4g s%s%s) -> %s\n", t.samples, aero_model_name(t.model),
              integrator_name(t.integrator), t.dt_s, t.autopilot ? ", autopilot " : "",
              t.autopilot ? (o.autopilot + (t.autopilot_finished ? ", finished" : "")).c_str() : "", o.out.c_str());
  if (o.compare) {
    if (!t.has_reference) throw io::InputError("--compare needs --reference");
    print_comparison(t.comparison, false);
  }
}

void run_derivatives(const SimulateRequest& o) {
  const aerobench_files::DerivativesOutcome d = aerobench_files::derivatives_to_file(o);
  std::printf("evaluated %zu %s points (%s) -> %s\n", d.points, d.closed_loop ? "closed-loop" : "plant",
              aero_model_name(d.model), o.out.c_str());
  if (o.compare) print_comparison(d.comparison, true);
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
  auto opts = std::make_shared<SimulateRequest>();
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
    aerobench_files::check_sources(*opts);
    if (!opts->derivatives.empty()) run_derivatives(*opts);
    else run_trajectory(*opts);
  });
}

}  // namespace f16race::app
