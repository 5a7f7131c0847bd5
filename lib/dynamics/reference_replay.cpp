#include "dynamics/reference_replay.hpp"

#include <algorithm>
#include <cmath>
#include <stdexcept>

#include "dynamics/inner_loop.hpp"

namespace f16race::dynamics {
namespace {

constexpr double kTimeTol_s = 1e-9;

ClosedLoopOutputs derivative(AeroModel model, const double* x, const double* u) {
  return model == AeroModel::kMorelli ? closed_loop_derivative<AeroModel::kMorelli>(x, u)
                                      : closed_loop_derivative<AeroModel::kStevens>(x, u);
}

}  // namespace

RefVector ReferenceSeries::at(double t, bool left_limit) const {
  RefVector u{};
  const std::size_t n = t_s.size();
  if (n == 0) return u;
  // Interval start j: last sample with t_j <= t (+tol), or strictly before t (-tol) for the
  // left limit, so the last stage of a step that ends on a switch still sees the old segment.
  const double key = left_limit ? t - kTimeTol_s : t + kTimeTol_s;
  const auto it = std::upper_bound(t_s.begin(), t_s.end(), key);
  std::size_t j = it == t_s.begin() ? 0 : static_cast<std::size_t>(it - t_s.begin()) - 1;
  if (interp == RefInterp::kHold || n == 1 || (j == 0 && t <= t_s.front())) {
    for (int r = 0; r < kNumRefs; ++r) u[r] = values[r][j];
    return u;
  }
  if (j + 1 == n) {  // past the last sample: hold it
    for (int r = 0; r < kNumRefs; ++r) u[r] = values[r].back();
    return u;
  }
  std::size_t k = j + 1;
  if (!segment.empty() && segment[j] != segment[k]) {
    // A switch happens at t_{j+1}: continue the current segment's trend instead.
    if (j == 0 || segment[j - 1] != segment[j]) {
      for (int r = 0; r < kNumRefs; ++r) u[r] = values[r][j];
      return u;
    }
    k = j;
    j = j - 1;
  }
  const double w = (t - t_s[j]) / (t_s[k] - t_s[j]);
  for (int r = 0; r < kNumRefs; ++r) u[r] = values[r][j] + w * (values[r][k] - values[r][j]);
  return u;
}

ReplaySample evaluate_closed_loop(AeroModel model, double t_s, const StateVector& x, const RefVector& u_ref) {
  const ClosedLoopOutputs o = derivative(model, x.data(), u_ref.data());
  ReplaySample s;
  s.t_s = t_s;
  s.x = x;
  for (int i = 0; i < kNumStates; ++i) s.xdot[i] = o.xdot[i];
  s.u_ref = u_ref;
  s.nz_g = o.nz_g;
  s.ps_radps = o.ps_radps;
  s.ny_r = o.ny_r;
  s.ny_g = o.ny_g;
  s.throttle = o.surfaces.throttle;
  s.elevator_deg = o.surfaces.elevator_deg;
  s.aileron_deg = o.surfaces.aileron_deg;
  s.rudder_deg = o.surfaces.rudder_deg;
  return s;
}

namespace {
// Recorded references as an outer loop without a mode.
class RecordedReferences final : public OuterLoop {
 public:
  explicit RecordedReferences(const ReferenceSeries& refs) : refs_(refs) {}
  RefVector u_ref(double t_s, const StateVector&, bool left_limit) const override { return refs_.at(t_s, left_limit); }

 private:
  const ReferenceSeries& refs_;
};
}  // namespace

ReplayResult replay_references(const ReplayRequest& req) {
  if (!(req.dt_s > 0.0)) throw std::invalid_argument("replay: dt must be > 0");
  const std::vector<double>& times = req.output_times_s;
  ReplayResult result;
  if (times.empty()) return result;
  result.samples.reserve(times.size());
  RecordedReferences recorded(req.refs);
  OuterLoop& loop = req.autopilot ? *req.autopilot : static_cast<OuterLoop&>(recorded);
  StateVector x = req.x0;
  // A sample: the discrete update first (AeroBench: "mode can change at time 0"), then the
  // outputs under the new mode, as its extended states are.
  auto record = [&](double t) {
    loop.at_sample(t, x);
    result.samples.push_back(evaluate_closed_loop(req.model, t, x, loop.u_ref(t, x, false)));
    result.samples.back().mode = loop.mode();
  };
  record(times[0]);

  for (std::size_t k = 0; k + 1 < times.size(); ++k) {
    const double t0 = times[k], t1 = times[k + 1];
    if (!(t1 > t0)) throw std::invalid_argument("replay: output times must increase strictly");
    // Equal steps no longer than dt that land exactly on the next output time.
    const int n = std::max(1, static_cast<int>(std::ceil((t1 - t0) / req.dt_s - 1e-9)));
    const double h = (t1 - t0) / n;
    for (int step = 0; step < n; ++step) {
      const double t = t0 + step * h;
      const double t_end = (step + 1 == n) ? t1 : t + h;
      StateVector xn;
      if (req.integrator == Integrator::kRk4) {
        // The outer loop at every stage, on the stage's state (AeroBench's right-hand side).
        const ClosedLoopOutputs k1 = derivative(req.model, x.data(), loop.u_ref(t, x, false).data());
        StateVector xs;
        for (int s = 0; s < kNumStates; ++s) xs[s] = x[s] + 0.5 * h * k1.xdot[s];
        const ClosedLoopOutputs k2 = derivative(req.model, xs.data(), loop.u_ref(t + 0.5 * h, xs, false).data());
        for (int s = 0; s < kNumStates; ++s) xs[s] = x[s] + 0.5 * h * k2.xdot[s];
        const ClosedLoopOutputs k3 = derivative(req.model, xs.data(), loop.u_ref(t + 0.5 * h, xs, false).data());
        for (int s = 0; s < kNumStates; ++s) xs[s] = x[s] + h * k3.xdot[s];
        const ClosedLoopOutputs k4 = derivative(req.model, xs.data(), loop.u_ref(t_end, xs, /*left_limit=*/true).data());
        for (int s = 0; s < kNumStates; ++s)
          xn[s] = x[s] + (h / 6.0) * (k1.xdot[s] + 2.0 * k2.xdot[s] + 2.0 * k3.xdot[s] + k4.xdot[s]);
      } else {
        const ClosedLoopOutputs k1 = derivative(req.model, x.data(), loop.u_ref(t, x, false).data());
        for (int s = 0; s < kNumStates; ++s) xn[s] = x[s] + h * k1.xdot[s];
      }
      const std::int32_t verdict = classify_state(xn.data(), req.limits);
      if (verdict != kStatusOk) {
        result.status = verdict;
        result.failed_at_s = t_end;
        return result;
      }
      x = xn;
    }
    record(t1);
    if (loop.finished(t1, x)) {
      result.autopilot_finished = true;
      break;
    }
  }
  return result;
}

}  // namespace f16race::dynamics
