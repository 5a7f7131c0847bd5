// AeroBench's outer loops flown natively (evaluated at every RK stage, modes switched at output
// samples): the GCAS run of tests/data reproduced to open-loop accuracy with the same switch
// times, and the rules of both autopilots checked on states built to sit on either side of them.
#include <gtest/gtest.h>

#include <cmath>
#include <cstring>
#include <string>
#include <vector>

#include <omp.h>

#include "aerobench_files/aerobench_csv.hpp"
#include "dynamics/autopilot_batch.hpp"
#include "dynamics/gcas_autopilot.hpp"
#include "dynamics/reference_replay.hpp"
#include "dynamics/waypoint_autopilot.hpp"
#include "reference_data.hpp"

namespace f16race::dynamics {
namespace {

constexpr double kPi = 3.14159265358979323846;

class GcasRun : public ::testing::TestWithParam<AeroModel> {};

TEST_P(GcasRun, ReproducesAeroBenchWithinOpenLoopTolerancesAndSwitchesOnTheSameSample) {
  const AeroModel model = GetParam();
  const io::CsvTable ref = test::load_reference(std::string("f_gcas_") + aero_model_name(model) + ".csv");
  aerobench_files::ReplaySettings settings;
  settings.model = model;
  settings.dt_s = 0.01;
  ReplayRequest req = aerobench_files::request_from_reference(ref, settings);
  GcasMode start;
  ASSERT_TRUE(parse_gcas_mode(aerobench_files::initial_mode(ref), &start));
  GcasAutopilot gcas(start);
  req.autopilot = &gcas;
  const ReplayResult res = replay_references(req);
  ASSERT_EQ(res.status, kStatusOk);
  ASSERT_EQ(res.samples.size(), ref.rows());
  double vt = 0, angle = 0, pos = 0;
  for (int s = 0; s < kNumStates; ++s) {
    const std::vector<double> theirs = ref.numeric(kStateNames[s]);
    for (std::size_t k = 0; k < theirs.size(); ++k) {
      const double e = std::fabs(res.samples[k].x[s] - theirs[k]);
      if (s == kVt) vt = std::fmax(vt, e);
      if (s >= kAlpha && s <= kPsi) angle = std::fmax(angle, e);
      if (s >= kPn && s <= kAlt) pos = std::fmax(pos, e);
    }
  }
  std::printf("[ native GCAS %s ] max error: vt %.2e ft/s, angles %.2e rad, position %.2e ft\n", aero_model_name(model),
              vt, angle, pos);
  // The open-loop tolerances (test_trajectories.cpp), not the 10x of the replay from samples.
  EXPECT_LT(vt, 0.05);
  EXPECT_LT(angle, 1e-4);
  EXPECT_LT(pos, 1.0);
  // Every row's mode, so both switches (roll -> pull, pull -> standby) happen on AeroBench's sample.
  const std::size_t mode_col = ref.column_index("mode");
  int switches = 0;
  for (std::size_t k = 0; k < ref.rows(); ++k) {
    EXPECT_EQ(res.samples[k].mode, ref.cell(k, mode_col)) << "row " << k << " t " << res.samples[k].t_s;
    if (k > 0 && ref.cell(k, mode_col) != ref.cell(k - 1, mode_col)) ++switches;
  }
  EXPECT_EQ(switches, 2);
  // And the references the law gave match the file's (ps of the roll law, Nz of the pull).
  const std::vector<double> ps_ref = ref.numeric("ps_ref_radps"), nz_ref = ref.numeric("Nz_ref_g");
  for (std::size_t k = 0; k < ref.rows(); ++k) {
    EXPECT_NEAR(res.samples[k].u_ref[kPsRef], ps_ref[k], 1e-3) << "row " << k;
    EXPECT_EQ(res.samples[k].u_ref[kNzRef], nz_ref[k]) << "row " << k;
  }
}

INSTANTIATE_TEST_SUITE_P(AeroBench, GcasRun, ::testing::Values(AeroModel::kMorelli, AeroModel::kStevens),
                         [](const auto& p) { return std::string(aero_model_name(p.param)); });

StateVector level_state() {
  StateVector x{};
  x[kVt] = 540.0;
  x[kAlpha] = 0.037;
  x[kTheta] = 0.037;
  x[kAlt] = 3800.0;
  x[kPow] = 9.0;
  return x;
}

TEST(GcasRules, EachTransitionNeedsAllOfItsConditions) {
  StateVector x = level_state();
  GcasState s;
  // Standby -> roll below the 1000 ft deck when θ − α is not above 0 (at exactly 0 it triggers).
  x[kAlt] = 900.0;
  EXPECT_TRUE(gcas_advance(&s, 0.0, x.data()));
  EXPECT_EQ(s.mode, GcasMode::kRoll);
  s.mode = GcasMode::kStandby;
  x[kTheta] = 0.05;  // nose up
  EXPECT_FALSE(gcas_advance(&s, 0.0, x.data()));
  x[kTheta] = -0.2;
  x[kAlt] = 1000.0;  // on the deck: not below it
  EXPECT_FALSE(gcas_advance(&s, 0.0, x.data()));
  x[kAlt] = 999.0;
  EXPECT_TRUE(gcas_advance(&s, 0.1, x.data()));
  EXPECT_EQ(s.mode, GcasMode::kRoll);
  // Roll -> pull needs |φ| < 5° (after wrapping) and |p| < 10°/s.
  x[kPhi] = 0.1;  // 5.7°
  EXPECT_FALSE(gcas_advance(&s, 0.2, x.data()));
  x[kPhi] = 2.0 * kPi + 0.05;  // a whole turn plus 2.9°: level
  x[kP] = 0.2;                 // 11.5°/s
  EXPECT_FALSE(gcas_advance(&s, 0.3, x.data()));
  x[kP] = 0.1;
  EXPECT_TRUE(gcas_advance(&s, 0.4, x.data()));
  EXPECT_EQ(s.mode, GcasMode::kPull);
  EXPECT_EQ(s.pull_start_s, 0.4);
  // Pull -> standby: nose above the horizon and at least 2 s of pulling.
  x[kTheta] = 0.3;
  EXPECT_FALSE(gcas_advance(&s, 2.39, x.data()));
  x[kTheta] = -0.1;
  EXPECT_FALSE(gcas_advance(&s, 2.5, x.data()));
  x[kTheta] = 0.3;
  EXPECT_TRUE(gcas_advance(&s, 2.41, x.data()));
  EXPECT_EQ(s.mode, GcasMode::kStandby);
  // Waiting -> roll at 2 s, with AeroBench's 1e-6 s of slack.
  s.mode = GcasMode::kWaiting;
  EXPECT_FALSE(gcas_advance(&s, 1.99, x.data()));
  EXPECT_TRUE(gcas_advance(&s, 2.0 - 5e-7, x.data()));
  EXPECT_EQ(s.mode, GcasMode::kRoll);
}

TEST(GcasRules, RollLawLevelsTheWingsTheShortWayAndPullIsFiveG) {
  StateVector x = level_state();
  x[kPhi] = -kPi / 8;
  x[kP] = 0.1;
  const RefVector roll = gcas_u_ref(GcasMode::kRoll, x.data());
  EXPECT_DOUBLE_EQ(roll[kPsRef], -4.0 * (-kPi / 8) - 2.0 * 0.1);
  x[kPhi] = 2.0 * kPi - 0.2;  // nearly a whole turn: roll back by 0.2, not forward by 2π − 0.2
  x[kP] = 0.0;
  EXPECT_NEAR(gcas_u_ref(GcasMode::kRoll, x.data())[kPsRef], 0.8, 1e-12);
  const RefVector pull = gcas_u_ref(GcasMode::kPull, x.data());
  EXPECT_EQ(pull[kNzRef], 5.0);
  EXPECT_EQ(pull[kPsRef], 0.0);
  for (GcasMode m : {GcasMode::kStandby, GcasMode::kWaiting})
    for (double u : gcas_u_ref(m, x.data())) EXPECT_EQ(u, 0.0);
}

TEST(WaypointRules, TurnsTowardTheWaypointWithinTheLimits) {
  StateVector x = level_state();  // heading north at the origin
  const std::vector<Waypoint> east{{0.0, 5000.0, 3800.0}};
  RefVector u = waypoint_u_ref(east, 0, x.data());
  // 90° to the right: the bank command saturates at +65°, ps = 0.75 · 65° from wings level.
  EXPECT_NEAR(u[kPsRef], 0.75 * 65.0 * kPi / 180.0, 1e-12);
  const std::vector<Waypoint> west{{0.0, -5000.0, 3800.0}};
  EXPECT_NEAR(waypoint_u_ref(west, 0, x.data())[kPsRef], -0.75 * 65.0 * kPi / 180.0, 1e-12);
  // Throttle: 0.25 per ft/s below 550, clipped to [0, 1]; Ny+r 0.
  EXPECT_EQ(u[kThrottleDelta], 1.0);  // 10 ft/s slow
  x[kVt] = 549.0;
  EXPECT_NEAR(waypoint_u_ref(east, 0, x.data())[kThrottleDelta], 0.25, 1e-12);
  x[kVt] = 600.0;
  EXPECT_EQ(waypoint_u_ref(east, 0, x.data())[kThrottleDelta], 0.0);
  EXPECT_EQ(u[kNyRRef], 0.0);
  // Altitude: Nz clipped to [-1, 4]; 10 000 ft low asks for the maximum.
  x = level_state();
  const std::vector<Waypoint> high{{5000.0, 0.0, 13800.0}}, low{{5000.0, 0.0, -6200.0}};
  EXPECT_EQ(waypoint_u_ref(high, 0, x.data())[kNzRef], 4.0);
  EXPECT_EQ(waypoint_u_ref(low, 0, x.data())[kNzRef], -1.0);
  // Descending in a bank of 15° or more: no push (Nz >= 0).
  x[kPhi] = 0.5;
  EXPECT_GE(waypoint_u_ref(low, 0, x.data())[kNzRef], 0.0);
  // Done (index past the end): wings level at the last altitude.
  x[kPhi] = 0.2;
  x[kP] = 0.0;
  EXPECT_NEAR(waypoint_u_ref(high, 1, x.data())[kPsRef], -0.75 * 0.2, 1e-12);
}

TEST(WaypointRules, FliesAeroBenchsExampleThroughEveryWaypointAndStopsFiveSecondsAfter) {
  // examples/waypoint/run_waypoint.py: 540 ft/s, α 2.1215°, ψ π/8 at 3800 ft, power 9, 70 s.
  StateVector x0{};
  x0[kVt] = 540.0;
  x0[kAlpha] = 2.1215 * kPi / 180.0;
  x0[kPsi] = kPi / 8;
  x0[kAlt] = 3800.0;
  x0[kPow] = 9.0;
  // (east, north, alt) as AeroBench lists them.
  const std::vector<Waypoint> wps{{3000.0, 1000.0, 4000.0}, {8000.0, 3000.0, 3900.0}, {18000.0, -1000.0, 3750.0},
                                  {28000.0, 500.0, 4000.0}};
  for (AeroModel model : {AeroModel::kMorelli, AeroModel::kStevens}) {
    ReplayRequest req;
    req.model = model;
    req.x0 = x0;
    for (double t = 0.0; t <= 70.0; t += 1.0 / 30.0) req.output_times_s.push_back(t);
    WaypointAutopilot ap(wps);
    req.autopilot = &ap;
    const ReplayResult res = replay_references(req);
    ASSERT_EQ(res.status, kStatusOk) << aero_model_name(model);
    ASSERT_TRUE(res.autopilot_finished) << aero_model_name(model) << ": did not pass all four waypoints in 70 s";
    // Each advance happened at a sample within 250 ft of the waypoint it left, in order.
    int next = 0;
    double done_s = -1.0;
    for (std::size_t k = 1; k < res.samples.size(); ++k) {
      if (res.samples[k].mode == res.samples[k - 1].mode) continue;
      const Waypoint& w = wps[static_cast<std::size_t>(next)];
      const StateVector& x = res.samples[k].x;
      const double d = std::sqrt(std::pow(w.n_ft - x[kPn], 2) + std::pow(w.e_ft - x[kPe], 2) +
                                 std::pow(w.alt_ft - x[kAlt], 2));
      EXPECT_LT(d, 250.0) << aero_model_name(model) << " waypoint " << next + 1;
      ++next;
      if (next == 4) done_s = res.samples[k].t_s;
    }
    EXPECT_EQ(next, 4) << aero_model_name(model);
    EXPECT_EQ(res.samples.back().mode, "Done");
    // The stop rule: the first sample more than 5 s after the last waypoint.
    EXPECT_GT(res.samples.back().t_s, done_s + 5.0);
    EXPECT_LE(res.samples.back().t_s, done_s + 5.0 + 1.0 / 30.0 + 1e-9);
    std::printf("[ native waypoint %s ] all four waypoints by t = %.2f s, stopped at %.2f s\n", aero_model_name(model),
                done_s, res.samples.back().t_s);
  }
}

// Heading convergence and altitude hold: from level flight heading north, a waypoint 30 000 ft
// due east at the same altitude. The bank-to-turn law brings the heading onto the bearing and
// the altitude law holds the height through the turn (no waypoint is reached in this time).
TEST(WaypointRules, ConvergesOnTheBearingAndHoldsAltitudeThroughTheTurn) {
  for (AeroModel model : {AeroModel::kMorelli, AeroModel::kStevens}) {
    ReplayRequest req;
    req.model = model;
    req.x0 = level_state();
    req.x0[kAlpha] = 2.1215 * kPi / 180.0;  // AeroBench's example start
    req.x0[kTheta] = 0.0;
    req.x0[kAlt] = 3800.0;
    for (double t = 0.0; t <= 40.0; t += 1.0 / 30.0) req.output_times_s.push_back(t);
    WaypointAutopilot ap({Waypoint{0.0, 30000.0, 3800.0}});
    req.autopilot = &ap;
    const ReplayResult res = replay_references(req);
    ASSERT_EQ(res.status, kStatusOk);
    double worst_alt = 0.0, heading_err_late = 0.0, t_converged = -1.0;
    for (const ReplaySample& s : res.samples) {
      worst_alt = std::fmax(worst_alt, std::fabs(s.x[kAlt] - 3800.0));
      const double bearing = std::atan2(0.0 - s.x[kPe] + 30000.0, 0.0 - s.x[kPn]);
      const double err = std::fabs(std::remainder(bearing - s.x[kPsi], 2.0 * kPi));
      if (err < 2.0 * kPi / 180.0 && t_converged < 0.0) t_converged = s.t_s;
      if (s.t_s >= 30.0) heading_err_late = std::fmax(heading_err_late, err);
    }
    std::printf("[ waypoint %s ] heading within 2 deg of the bearing at t = %.1f s, worst after 30 s %.2f deg; "
                "worst altitude error %.1f ft\n",
                aero_model_name(model), t_converged, heading_err_late * 180.0 / kPi, worst_alt);
    EXPECT_GT(t_converged, 0.0);
    EXPECT_LT(t_converged, 30.0);
    EXPECT_LT(heading_err_late, 2.0 * kPi / 180.0);
    EXPECT_LT(worst_alt, 200.0);
  }
}

// The batched autopilots (F16Batch evaluating the law at every RK stage of every lane) against
// the single-aircraft replay, aircraft by aircraft: every sample's state and mode, the sample
// count, the envelope failures and their times, the stop rule. A test of the batch's plumbing
// (law rows, mode updates, per-aircraft stops); the replay itself is held to AeroBench above.
struct BatchedTrajectories {
  AutopilotBatchResult result;
  std::vector<std::vector<StateVector>> states;  // [aircraft][sample]
  std::vector<std::vector<RefVector>> refs;      // [aircraft][sample]
};

BatchedTrajectories fly_batched(const AutopilotBatchRequest& req) {
  BatchedTrajectories out;
  out.states.resize(req.x0.size());
  out.refs.resize(req.x0.size());
  out.result = fly_autopilot_batch(req, [&](double, const F16Batch& b, const std::vector<char>& sampled) {
    for (std::size_t i = 0; i < req.x0.size(); ++i) {
      if (!sampled[i]) continue;
      out.states[i].push_back(b.aircraft_state(static_cast<int>(i)));
      RefVector u;
      for (int r = 0; r < kNumRefs; ++r) u[r] = b.ref(r)[i];
      out.refs[i].push_back(u);
    }
  });
  return out;
}

// Largest |batch − replay| over every state of every sample, relative to max(1, |value|).
double compare_with_replay(const BatchedTrajectories& bt, std::size_t i, const ReplayResult& one) {
  const AutopilotAircraftResult& a = bt.result.aircraft[i];
  EXPECT_EQ(a.samples, static_cast<int>(one.samples.size())) << "aircraft " << i;
  EXPECT_EQ(bt.states[i].size(), one.samples.size()) << "aircraft " << i;
  EXPECT_EQ(a.status, one.status) << "aircraft " << i;
  if (one.status != kStatusOk) {
    EXPECT_DOUBLE_EQ(a.failed_at_s, one.failed_at_s) << "aircraft " << i;
  }
  EXPECT_EQ(a.finished, one.autopilot_finished) << "aircraft " << i;
  if (!one.samples.empty()) {
    EXPECT_EQ(a.mode, one.samples.back().mode) << "aircraft " << i;
  }
  double worst = 0.0;
  const std::size_t n = std::min(bt.states[i].size(), one.samples.size());
  for (std::size_t k = 0; k < n; ++k) {
    for (int s = 0; s < kNumStates; ++s)
      worst = std::fmax(worst, std::fabs(bt.states[i][k][s] - one.samples[k].x[s]) /
                                   std::fmax(1.0, std::fabs(one.samples[k].x[s])));
    for (int r = 0; r < kNumRefs; ++r)
      worst = std::fmax(worst, std::fabs(bt.refs[i][k][r] - one.samples[k].u_ref[r]) /
                                   std::fmax(1.0, std::fabs(one.samples[k].u_ref[r])));
  }
  return worst;
}

void expect_same_bytes_at_1_and_2_threads(const AutopilotBatchRequest& req) {
  const int before = omp_get_max_threads();
  omp_set_num_threads(1);
  const BatchedTrajectories one = fly_batched(req);
  omp_set_num_threads(2);
  const BatchedTrajectories two = fly_batched(req);
  omp_set_num_threads(before);
  for (std::size_t i = 0; i < req.x0.size(); ++i) {
    ASSERT_EQ(one.states[i].size(), two.states[i].size());
    for (std::size_t k = 0; k < one.states[i].size(); ++k)
      ASSERT_EQ(0, std::memcmp(one.states[i][k].data(), two.states[i][k].data(), sizeof(StateVector)))
          << "aircraft " << i << " sample " << k;
  }
}

TEST(AutopilotBatch, GcasFromManyStartsEqualsOneReplayPerAircraftAtAnyThreadCount) {
  for (AeroModel model : {AeroModel::kMorelli, AeroModel::kStevens}) {
    const io::CsvTable ref = test::load_reference(std::string("f_gcas_") + aero_model_name(model) + ".csv");
    aerobench_files::ReplaySettings settings;
    settings.model = model;
    const ReplayRequest base = aerobench_files::request_from_reference(ref, settings);
    AutopilotBatchRequest req;
    req.model = model;
    req.law = StageLaw::kGcas;
    req.output_times_s = base.output_times_s;
    // Higher floor than the default so the lowest dives leave the envelope mid-run.
    req.limits.alt_min_ft = 600.0;
    // AeroBench's f_gcas start (1000 ft, nose 27° down, 22.5° left bank) and 20 variations of
    // altitude, bank and pitch; some start in standby above the deck and never trigger.
    for (int k = 0; k < 21; ++k) {
      StateVector x = base.x0;
      x[kAlt] += 150.0 * (k % 7) - 300.0;
      x[kPhi] += 0.35 * ((k / 7) - 1);
      x[kTheta] *= 0.6 + 0.2 * (k % 3);
      req.x0.push_back(x);
      req.gcas_modes.push_back(k % 5 == 4 ? GcasMode::kWaiting : GcasMode::kStandby);
    }
    const BatchedTrajectories bt = fly_batched(req);
    int failed = 0, pulled = 0;
    double worst = 0.0;
    for (std::size_t i = 0; i < req.x0.size(); ++i) {
      ReplayRequest one = base;
      one.x0 = req.x0[i];
      one.limits = req.limits;
      GcasAutopilot ap(req.gcas_modes[i]);
      one.autopilot = &ap;
      worst = std::fmax(worst, compare_with_replay(bt, i, replay_references(one)));
      failed += bt.result.aircraft[i].status != kStatusOk;
      pulled += bt.result.aircraft[i].mode != "standby" || bt.result.aircraft[i].min_alt_ft < 1000.0;
    }
    std::printf("[ batched GCAS %s ] 21 aircraft: %d left the envelope, worst relative difference %.2e\n",
                aero_model_name(model), failed, worst);
    EXPECT_LT(worst, 1e-9);
    EXPECT_GT(failed, 0);          // the failure path is exercised
    EXPECT_LT(failed, 21);
    EXPECT_GT(pulled, 0);
    expect_same_bytes_at_1_and_2_threads(req);
  }
}

TEST(AutopilotBatch, WaypointRunsStopPerAircraftAsTheReplayDoes) {
  // AeroBench's waypoint example from four headings; one list shared by every aircraft.
  const std::vector<Waypoint> wps{{3000.0, 1000.0, 4000.0}, {8000.0, 3000.0, 3900.0}, {18000.0, -1000.0, 3750.0},
                                  {28000.0, 500.0, 4000.0}};
  AutopilotBatchRequest req;
  req.law = StageLaw::kWaypoint;
  req.waypoints = {wps};
  for (double t = 0.0; t <= 75.0; t += 1.0 / 30.0) req.output_times_s.push_back(t);
  for (int k = 0; k < 4; ++k) {
    StateVector x0{};
    x0[kVt] = 540.0;
    x0[kAlpha] = 2.1215 * kPi / 180.0;
    x0[kPsi] = kPi / 8 + k * kPi / 6;
    x0[kAlt] = 3800.0 + 100.0 * k;
    x0[kPow] = 9.0;
    req.x0.push_back(x0);
  }
  const BatchedTrajectories bt = fly_batched(req);
  double worst = 0.0;
  int finished = 0;
  for (std::size_t i = 0; i < req.x0.size(); ++i) {
    ReplayRequest one;
    one.x0 = req.x0[i];
    one.output_times_s = req.output_times_s;
    WaypointAutopilot ap(wps);
    one.autopilot = &ap;
    worst = std::fmax(worst, compare_with_replay(bt, i, replay_references(one)));
    finished += bt.result.aircraft[i].finished;
  }
  std::printf("[ batched waypoint ] 4 aircraft, %d finished, worst relative difference %.2e\n", finished, worst);
  EXPECT_LT(worst, 1e-9);
  EXPECT_GE(finished, 1);  // the per-aircraft stop is exercised
  expect_same_bytes_at_1_and_2_threads(req);
}

TEST(AutopilotBatch, RefusesInconsistentRequests) {
  AutopilotBatchRequest req;
  req.law = StageLaw::kWaypoint;
  req.output_times_s = {0.0, 1.0};
  req.x0.assign(2, level_state());
  EXPECT_THROW(fly_autopilot_batch(req), std::invalid_argument);  // no waypoint list
  req.waypoints = {{Waypoint{}}, {Waypoint{}}, {Waypoint{}}};
  EXPECT_THROW(fly_autopilot_batch(req), std::invalid_argument);  // 3 lists for 2 aircraft
  req.waypoints = {{}};
  EXPECT_THROW(fly_autopilot_batch(req), std::invalid_argument);  // an empty list
  req.law = StageLaw::kHeld;
  EXPECT_THROW(fly_autopilot_batch(req), std::invalid_argument);
  req.law = StageLaw::kGcas;
  req.gcas_modes = {GcasMode::kRoll};
  EXPECT_THROW(fly_autopilot_batch(req), std::invalid_argument);  // 1 mode for 2 aircraft
  req.gcas_modes.clear();
  req.output_times_s = {0.0, 0.0};
  EXPECT_THROW(fly_autopilot_batch(req), std::invalid_argument);
  F16Batch held(F16BatchConfig{});
  EXPECT_THROW(held.law(kLawMode), std::logic_error);
}

}  // namespace
}  // namespace f16race::dynamics
