#include "aerobench_files/aerobench_csv.hpp"

#include <algorithm>
#include <array>
#include <cmath>
#include <cstdio>
#include <string>

#include "dynamics/model_probe.hpp"
#include "dynamics/trim.hpp"
#include "io/input_error.hpp"

namespace f16race::aerobench_files {

using namespace f16race::dynamics;

namespace {

// The surface inputs of a plant-point file (deriv_plant_*), named as AeroBench's subf16_model
// takes them; trajectories name the commanded surfaces kSurfaceNames instead.
constexpr std::array<const char*, 4> kPlantSurfaceColumns = {"throttle", "elevator_deg", "aileron_deg", "rudder_deg"};

// Every number these files give enters a computation (a start state, a reference, a time), so
// nan, inf and overflowing cells are refused with the file, line and column.
std::vector<double> require_column(const io::CsvTable& t, const std::string& name) {
  if (!t.has_column(name))
    throw io::InputError(t.source() + ": missing column '" + name + "' (the AeroBench reference format names it so)");
  return t.finite(name);
}

std::string short_number(double v) {
  char buf[32];
  std::snprintf(buf, sizeof buf, "%.6g", v);
  return buf;
}

// A start state outside the model's domain would be frozen before its first step, and a point
// outside it evaluated on extrapolated tables (or divided by an airspeed of 0): refused naming
// the file, its line and the column.
void require_state_in_domain(const io::CsvTable& t, std::size_t row, const StateVector& x, const char* what) {
  double lo = 0.0, hi = 0.0;
  const int s = first_state_outside_domain(x, EnvelopeLimits{}, &lo, &hi);
  if (s < 0) return;
  std::string range = "[" + short_number(lo) + ", " + short_number(hi) + "]";
  if (s == kAlpha || s == kBeta || s == kTheta)
    range += " rad (" + short_number(lo / kDegToRad) + " to " + short_number(hi / kDegToRad) + " deg)";
  throw io::InputError(t.source() + ":" + std::to_string(t.line_of_row(row)) + ": " + what + " " + kStateNames[s] +
                       " = " + short_number(x[s]) + " is outside the model's domain " + range + "; give a " + what +
                       " inside it");
}

// Line numbers in messages count the header as line 1.
void require_increasing(const std::vector<double>& t_s, const std::string& source) {
  for (std::size_t j = 1; j < t_s.size(); ++j)
    if (!(t_s[j] > t_s[j - 1]))
      throw io::InputError(source + ": t_s must increase strictly (line " + std::to_string(j + 2) + ")");
}

ReplayRequest settings_request(const ReplaySettings& s) {
  ReplayRequest req;
  req.model = s.model;
  req.integrator = s.integrator;
  req.refs.interp = s.interp;
  req.dt_s = s.dt_s;
  return req;
}

}  // namespace

ReplayRequest request_from_reference(const io::CsvTable& reference, const ReplaySettings& settings) {
  ReplayRequest req = settings_request(settings);
  req.output_times_s = require_column(reference, "t_s");
  if (req.output_times_s.empty()) throw io::InputError(reference.source() + ": no data rows");
  require_increasing(req.output_times_s, reference.source());
  for (int s = 0; s < kNumStates; ++s) req.x0[s] = require_column(reference, kStateNames[s]).front();
  require_state_in_domain(reference, 0, req.x0, "start state");
  req.refs.t_s = req.output_times_s;
  for (int r = 0; r < kNumRefs; ++r) req.refs.values[r] = require_column(reference, kRefNames[r]);
  if (reference.has_column("mode")) {
    const std::size_t c = reference.column_index("mode");
    for (std::size_t k = 0; k < reference.rows(); ++k) {
      const bool changed = k > 0 && reference.cell(k, c) != reference.cell(k - 1, c);
      req.refs.segment.push_back(k == 0 ? 0 : req.refs.segment.back() + (changed ? 1 : 0));
    }
  }
  return req;
}

ReplayRequest request_from_commands(const io::CsvTable* commands, const ScriptedRun& run,
                                    const ReplaySettings& settings) {
  ReplayRequest req = settings_request(settings);
  if (!(run.duration_s > 0.0) || !(run.sample_s > 0.0)) throw io::InputError("--duration and --sample must be > 0");
  // Checked before the cast: a huge ratio would overflow int and simulate nothing.
  if (run.duration_s / run.sample_s > ScriptedRun::kMaxSamples)
    throw io::InputError("--duration " + short_number(run.duration_s) + " s at --sample " + short_number(run.sample_s) +
                         " s would write more than 10 000 000 samples; shorten --duration or raise --sample");
  TrimRequest trim_req;
  trim_req.model = settings.model;
  trim_req.vt_ftps = run.trim_vt_ftps;
  trim_req.alt_ft = run.trim_alt_ft;
  TrimResult trim;
  try {
    trim = trim_level_flight(trim_req);
  } catch (const TrimError& e) {
    throw io::InputError(std::string("--trim-vt/--trim-alt: ") + e.what());
  }
  req.x0 = trim.x0;
  const int n = static_cast<int>(std::floor(run.duration_s / run.sample_s + 1e-9));
  for (int k = 0; k <= n; ++k) req.output_times_s.push_back(k * run.sample_s);
  if (commands == nullptr) {
    req.refs.t_s = {0.0};
    for (int r = 0; r < kNumRefs; ++r) req.refs.values[r] = {trim.u_ref[r]};
    return req;
  }
  const std::string& src = commands->source();
  req.refs.t_s = require_column(*commands, "t_s");
  // No rows would fly every reference at 0 instead of the trim values.
  if (req.refs.t_s.empty())
    throw io::InputError(src + ": has a header but no rows; give at least one row (t_s = 0 and the deltas "
                               "from trim), or leave out --commands to fly at trim");
  require_increasing(req.refs.t_s, src);
  bool any = false;
  for (int r = 0; r < kNumRefs; ++r) {
    std::vector<double> v(req.refs.t_s.size(), 0.0);
    if (commands->has_column(kRefNames[r])) {
      v = commands->finite(kRefNames[r]);
      any = true;
    }
    for (double& x : v) x += trim.u_ref[r];
    req.refs.values[r] = v;
  }
  if (!any)
    throw io::InputError(src + ": needs t_s and at least one of Nz_ref_g, ps_ref_radps, Ny_r_ref_mixed, "
                               "throttle_ref_delta");
  return req;
}

std::vector<Waypoint> read_waypoints(const io::CsvTable& t) {
  const std::vector<double> e = require_column(t, "e_ft"), n = require_column(t, "n_ft"), alt = require_column(t, "alt_ft");
  if (e.empty()) throw io::InputError(t.source() + ": no waypoints; give one row per waypoint (e_ft, n_ft, alt_ft)");
  std::vector<Waypoint> w(e.size());
  for (std::size_t k = 0; k < e.size(); ++k) w[k] = Waypoint{n[k], e[k], alt[k]};
  return w;
}

std::string initial_mode(const io::CsvTable& t) {
  return t.has_column("mode") && t.rows() > 0 ? t.cell(0, t.column_index("mode")) : std::string();
}

ReplayRequest request_from_initial_state(const io::CsvTable& init, double duration_s, double sample_s,
                                         const ReplaySettings& settings) {
  ReplayRequest req = settings_request(settings);
  req.x0 = initial_states(init).front();
  req.output_times_s = sample_times(duration_s, sample_s);
  return req;
}

std::vector<StateVector> initial_states(const io::CsvTable& init) {
  if (init.rows() == 0) throw io::InputError(init.source() + ": no data rows; the first row is the start state");
  std::vector<StateVector> x(init.rows(), StateVector{});
  for (int s = 0; s < kNumStates; ++s) {
    const bool integrator = s >= kNumPlantStates;
    if (integrator && !init.has_column(kStateNames[s])) continue;  // the integrators start at 0
    const std::vector<double> column = require_column(init, kStateNames[s]);
    for (std::size_t k = 0; k < x.size(); ++k) x[k][s] = column[k];
  }
  for (std::size_t k = 0; k < x.size(); ++k) require_state_in_domain(init, k, x[k], "start state");
  return x;
}

std::vector<std::string> row_modes(const io::CsvTable& t) {
  std::vector<std::string> modes(t.rows());
  if (!t.has_column("mode")) return modes;
  const std::size_t c = t.column_index("mode");
  for (std::size_t k = 0; k < modes.size(); ++k) modes[k] = t.cell(k, c);
  return modes;
}

std::vector<double> sample_times(double duration_s, double sample_s) {
  if (!(duration_s > 0.0) || !(sample_s > 0.0)) throw io::InputError("--duration and --sample must be > 0");
  if (duration_s / sample_s > ScriptedRun::kMaxSamples)
    throw io::InputError("--duration " + short_number(duration_s) + " s at --sample " + short_number(sample_s) +
                         " s would write more than 10 000 000 samples; shorten --duration or raise --sample");
  std::vector<double> times;
  // Accumulated like run_f16_sim's sample times, so mode switches see the same clock values.
  for (double t = 0.0; t <= duration_s; t += sample_s) times.push_back(t);
  return times;
}

std::vector<std::string> trajectory_header() {
  std::vector<std::string> h{"t_s"};
  for (const char* n : kStateNames) h.push_back(n);
  for (const char* n : {"Nz_g", "ps_radps", "Ny_r_mixed", "Ny_g"}) h.push_back(n);
  for (const char* n : kRefNames) h.push_back(n);
  for (const char* n : kSurfaceNames) h.push_back(n);
  for (const char* n : kStateDerivativeNames) h.push_back(n);
  return h;
}

std::vector<std::vector<double>> trajectory_rows(const ReplayResult& result) {
  std::vector<std::vector<double>> rows;
  rows.reserve(result.samples.size());
  for (const ReplaySample& s : result.samples) {
    std::vector<double> row{s.t_s};
    row.insert(row.end(), s.x.begin(), s.x.end());
    row.insert(row.end(), {s.nz_g, s.ps_radps, s.ny_r, s.ny_g});
    row.insert(row.end(), s.u_ref.begin(), s.u_ref.end());
    row.insert(row.end(), {s.throttle, s.elevator_deg, s.aileron_deg, s.rudder_deg});
    row.insert(row.end(), s.xdot.begin(), s.xdot.end());
    rows.push_back(std::move(row));
  }
  return rows;
}

DerivativeTable evaluate_derivatives(const io::CsvTable& points, AeroModel model) {
  DerivativeTable out;
  out.closed_loop = points.has_column(kRefNames[0]);
  std::vector<std::vector<double>> inputs;
  const int n_states = out.closed_loop ? kNumStates : kNumPlantStates;
  for (int s = 0; s < n_states; ++s) out.header.push_back(kStateNames[s]);
  if (out.closed_loop) out.header.insert(out.header.end(), kRefNames.begin(), kRefNames.end());
  else out.header.insert(out.header.end(), kPlantSurfaceColumns.begin(), kPlantSurfaceColumns.end());
  for (const std::string& name : out.header) inputs.push_back(require_column(points, name));
  out.n_inputs = inputs.size();
  const std::size_t n = points.rows();
  out.rows.resize(n);
  for (std::size_t r = 0; r < n; ++r) {
    std::vector<NamedValue> values;
    StateVector point{};  // a plant point's integrators are 0
    for (int s = 0; s < n_states; ++s) point[s] = inputs[s][r];
    require_state_in_domain(points, r, point, "state");
    if (out.closed_loop) {
      StateVector x;
      RefVector u;
      for (int s = 0; s < kNumStates; ++s) x[s] = inputs[s][r];
      for (int k = 0; k < kNumRefs; ++k) u[k] = inputs[kNumStates + k][r];
      values = probe_closed_loop(model, x, u);
    } else {
      double x[kNumPlantStates];
      for (int s = 0; s < kNumPlantStates; ++s) x[s] = inputs[s][r];
      const SurfaceCommands u{inputs[kNumPlantStates][r], inputs[kNumPlantStates + 1][r],
                              inputs[kNumPlantStates + 2][r], inputs[kNumPlantStates + 3][r]};
      values = probe_plant(model, x, u);
    }
    if (r == 0)
      for (const NamedValue& v : values) out.header.push_back(v.name);
    for (std::size_t c = 0; c < out.n_inputs; ++c) out.rows[r].push_back(inputs[c][r]);
    for (const NamedValue& v : values) out.rows[r].push_back(v.value);
  }
  if (points.has_column("case")) {
    const std::size_t c = points.column_index("case");
    for (std::size_t r = 0; r < n; ++r) out.cases.push_back(points.cell(r, c));
  }
  return out;
}

std::vector<ColumnDiff> compare_columns(const io::CsvTable& theirs, const std::vector<std::string>& header,
                                        const std::vector<std::vector<double>>& rows, std::size_t first_column,
                                        bool relative) {
  std::vector<ColumnDiff> out;
  for (std::size_t c = first_column; c < header.size(); ++c) {
    if (!theirs.has_column(header[c])) continue;
    const std::vector<double> ref = theirs.numeric(header[c]);
    ColumnDiff d{header[c], 0.0, 0};
    for (std::size_t r = 0; r < rows.size() && r < ref.size(); ++r) {
      double e = std::fabs(rows[r][c] - ref[r]);
      if (relative) e /= std::max(1.0, std::fabs(ref[r]));
      if (!(e <= d.worst)) {  // also catches NaN
        d.worst = e;
        d.at_row = r;
      }
    }
    out.push_back(d);
  }
  return out;
}

void write_rows(const std::string& path, const std::vector<std::string>& header,
                const std::vector<std::vector<double>>& rows, const std::vector<std::string>& string_header,
                const std::vector<std::vector<std::string>>& string_columns) {
  std::vector<std::vector<double>> cols(header.size(), std::vector<double>(rows.size()));
  for (std::size_t r = 0; r < rows.size(); ++r)
    for (std::size_t c = 0; c < header.size(); ++c) cols[c][r] = rows[r][c];
  io::write_csv(path, header, cols, string_header, string_columns);
}

}  // namespace f16race::aerobench_files
