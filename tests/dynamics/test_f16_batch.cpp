// The batched simulator: agreement with the single-aircraft path, bit-identical results at
// any thread count, NaN containment and envelope flagging.
#include <gtest/gtest.h>
#include <omp.h>

#include <cmath>
#include <cstring>
#include <limits>
#include <vector>

#include "dynamics/f16_batch.hpp"
#include "dynamics/reference_replay.hpp"
#include "dynamics/trim.hpp"

namespace f16race::dynamics {
namespace {

TrimResult trim_at(AeroModel model, double vt, double alt) {
  TrimRequest req;
  req.model = model;
  req.vt_ftps = vt;
  req.alt_ft = alt;
  return trim_level_flight(req);
}

// A varied fleet: trims at several speeds with different commands per aircraft.
void fill_fleet(F16Batch& b, AeroModel model) {
  std::vector<TrimResult> trims;
  for (int k = 0; k < 5; ++k) trims.push_back(trim_at(model, 450.0 + 80.0 * k, 3000.0 + 4000.0 * k));
  for (int i = 0; i < b.size(); ++i) {
    const TrimResult& t = trims[i % 5];
    RefVector u = t.u_ref;
    u[kNzRef] += 0.5 * ((i * 7) % 9) - 1.0;        // -1 .. 3 g extra
    u[kPsRef] += 0.1 * ((i * 5) % 11) - 0.5;       // -0.5 .. 0.5 rad/s
    u[kThrottleDelta] += 0.05 * ((i * 3) % 7) - 0.1;
    b.reset_aircraft(i, t.x0, u);
  }
}

std::vector<double> snapshot(const F16Batch& b) {
  std::vector<double> v;
  for (int s = 0; s < kNumStates; ++s) v.insert(v.end(), b.state(s), b.state(s) + b.size());
  return v;
}

class Batch : public ::testing::TestWithParam<AeroModel> {};

TEST_P(Batch, MatchesSingleAircraftReplay) {
  const AeroModel model = GetParam();
  F16BatchConfig cfg;
  cfg.n_env = 5;
  cfg.n_agent = 7;  // 35 aircraft: not a multiple of the block size, so padding is exercised
  cfg.model = model;
  F16Batch batch(cfg);
  fill_fleet(batch, model);
  std::vector<StateVector> x0(batch.size());
  std::vector<RefVector> u(batch.size());
  for (int i = 0; i < batch.size(); ++i) {
    x0[i] = batch.aircraft_state(i);
    for (int r = 0; r < kNumRefs; ++r) u[i][r] = batch.ref(r)[i];
  }
  ASSERT_EQ(batch.step(0.01, 300), 0);  // 3 s
  for (int i = 0; i < batch.size(); i += 3) {
    ReplayRequest req;
    req.model = model;
    req.dt_s = 0.01;
    req.x0 = x0[i];
    req.refs.t_s = {0.0};
    for (int r = 0; r < kNumRefs; ++r) req.refs.values[r] = {u[i][r]};
    req.output_times_s = {0.0, 3.0};
    const ReplayResult res = replay_references(req);
    ASSERT_EQ(res.samples.size(), 2u);
    const StateVector xb = batch.aircraft_state(i);
    for (int s = 0; s < kNumStates; ++s)
      EXPECT_NEAR(xb[s], res.samples[1].x[s], 1e-7 * std::max(1.0, std::fabs(xb[s]))) << "aircraft " << i << " " << kStateNames[s];
  }
}

TEST_P(Batch, BitIdenticalForOneAndTwoThreads) {
  const AeroModel model = GetParam();
  std::vector<double> results[2];
  for (int t = 1; t <= 2; ++t) {
    omp_set_num_threads(t);
    F16BatchConfig cfg;
    cfg.n_env = 37;
    cfg.n_agent = 8;
    cfg.model = model;
    F16Batch batch(cfg);
    fill_fleet(batch, model);
    batch.step(0.01, 50);
    batch.step(0.02, 25);
    results[t - 1] = snapshot(batch);
  }
  omp_set_num_threads(omp_get_num_procs());
  ASSERT_EQ(results[0].size(), results[1].size());
  EXPECT_EQ(0, std::memcmp(results[0].data(), results[1].data(), results[0].size() * sizeof(double)));
}

TEST_P(Batch, NanStaysInItsAircraft) {
  const AeroModel model = GetParam();
  F16BatchConfig cfg;
  cfg.n_env = 4;
  cfg.n_agent = 8;
  cfg.model = model;
  F16Batch clean(cfg), dirty(cfg);
  fill_fleet(clean, model);
  fill_fleet(dirty, model);
  const int bad = 13;  // mid-block lane
  dirty.state(kAlpha)[bad] = std::numeric_limits<double>::quiet_NaN();
  const StateVector frozen = dirty.aircraft_state(bad);
  EXPECT_EQ(dirty.step(0.01, 20), 1);
  EXPECT_EQ(dirty.status()[bad], kStatusNonFinite);
  clean.step(0.01, 20);
  for (int i = 0; i < cfg.n_env * cfg.n_agent; ++i) {
    if (i == bad) continue;
    EXPECT_EQ(dirty.status()[i], kStatusOk);
    for (int s = 0; s < kNumStates; ++s) ASSERT_EQ(dirty.state(s)[i], clean.state(s)[i]) << i << " " << s;
  }
  // The frozen aircraft keeps the state it had, and later steps do not count it again.
  const StateVector after = dirty.aircraft_state(bad);
  for (int s = 0; s < kNumStates; ++s) {
    if (s == kAlpha) continue;  // NaN != NaN
    EXPECT_EQ(after[s], frozen[s]);
  }
  EXPECT_EQ(dirty.step(0.01, 5), 0);
  dirty.evaluate_outputs();
  for (int i = 0; i < cfg.n_env * cfg.n_agent; ++i) {
    if (i == bad) continue;
    EXPECT_TRUE(std::isfinite(dirty.output(kOutNz)[i]));
  }
}

TEST_P(Batch, EnvelopeViolationsAreFlaggedAndFrozen) {
  const AeroModel model = GetParam();
  F16BatchConfig cfg;
  cfg.n_env = 8;
  cfg.model = model;
  F16Batch b(cfg);
  const TrimResult t = trim_at(model, 600.0, 10000.0);
  for (int i = 0; i < 8; ++i) b.reset_aircraft(i, t.x0, t.u_ref);
  const double deg = 3.141592653589793 / 180.0;
  b.state(kAlpha)[1] = 46.0 * deg;
  b.state(kAlpha)[2] = -11.0 * deg;
  b.state(kBeta)[3] = 31.0 * deg;
  b.state(kTheta)[4] = 86.0 * deg;
  b.state(kVt)[5] = 40.0;
  b.state(kAlt)[6] = 120000.0;
  const StateVector before1 = b.aircraft_state(1);
  EXPECT_EQ(b.step(0.01, 1), 6);
  EXPECT_EQ(b.status()[0], kStatusOk);
  EXPECT_EQ(b.status()[1], kStatusAlpha);
  EXPECT_EQ(b.status()[2], kStatusAlpha);
  EXPECT_EQ(b.status()[3], kStatusBeta);
  EXPECT_EQ(b.status()[4], kStatusTheta);
  EXPECT_EQ(b.status()[5], kStatusSpeed);
  EXPECT_EQ(b.status()[6], kStatusAltitude);
  EXPECT_EQ(b.status()[7], kStatusOk);
  const StateVector after1 = b.aircraft_state(1);
  for (int s = 0; s < kNumStates; ++s) EXPECT_EQ(after1[s], before1[s]);
  // A reset brings a frozen aircraft back.
  b.reset_aircraft(1, t.x0, t.u_ref);
  EXPECT_EQ(b.step(0.01, 1), 0);
  EXPECT_EQ(b.status()[1], kStatusOk);
}

TEST_P(Batch, HardPullIsFlaggedBeforeItCanBlowUp) {
  // Full-back stick at low speed drives alpha past the tables; the aircraft must stop at the
  // envelope with finite numbers, never run on into NaN.
  const AeroModel model = GetParam();
  F16BatchConfig cfg;
  cfg.model = model;
  F16Batch b(cfg);
  const TrimResult t = trim_at(model, 350.0, 20000.0);
  RefVector u = t.u_ref;
  u[kNzRef] = 6.0;
  u[kThrottleDelta] = -0.2;
  b.reset_aircraft(0, t.x0, u);
  int failed = 0;
  for (int k = 0; k < 3000 && failed == 0; ++k) failed = b.step(0.01, 1);
  EXPECT_EQ(failed, 1);
  EXPECT_NE(b.status()[0], kStatusOk);
  EXPECT_NE(b.status()[0], kStatusNonFinite);
  for (int s = 0; s < kNumStates; ++s) EXPECT_TRUE(std::isfinite(b.state(s)[0]));
}

TEST_P(Batch, EulerConvergesToRk4AsStepShrinks) {
  const AeroModel model = GetParam();
  auto run = [&](Integrator integ, double dt, int steps) {
    F16BatchConfig cfg;
    cfg.model = model;
    cfg.integrator = integ;
    F16Batch b(cfg);
    TrimResult t = trim_at(model, 500.0, 8000.0);
    RefVector u = t.u_ref;
    u[kNzRef] += 1.0;
    b.reset_aircraft(0, t.x0, u);
    b.step(dt, steps);
    return b.aircraft_state(0);
  };
  const StateVector ref = run(Integrator::kRk4, 0.005, 400);
  const double e1 = std::fabs(run(Integrator::kEuler, 0.002, 1000)[kAlt] - ref[kAlt]);
  const double e2 = std::fabs(run(Integrator::kEuler, 0.001, 2000)[kAlt] - ref[kAlt]);
  EXPECT_LT(e2, 0.7 * e1);  // first order: halving dt roughly halves the error
  EXPECT_LT(e2, 5.0);
}

TEST(BatchLayout, PaddingLanesAreNeverAircraft) {
  F16BatchConfig cfg;
  cfg.n_env = 3;
  cfg.n_agent = 3;
  F16Batch b(cfg);
  EXPECT_EQ(b.size(), 9);
  EXPECT_EQ(b.padded_size() % F16Batch::kBlock, 0);
  for (int i = b.size(); i < b.padded_size(); ++i) EXPECT_EQ(b.status()[i], kStatusPadding);
  EXPECT_EQ(reinterpret_cast<std::uintptr_t>(b.state(0)) % 64, 0u);
  EXPECT_EQ(b.step(0.01, 10), 0);
  for (int i = b.size(); i < b.padded_size(); ++i) EXPECT_EQ(b.status()[i], kStatusPadding);
}

// The AVX-512 copies of the kernels (chosen at run time where the build lacks them) give the
// build's own bits: states, envelope verdicts and outputs, for every integrator and stage law,
// through hard pulls and turns that trip a tightened envelope. Skipped where this CPU has no AVX-512.
TEST_P(Batch, WideKernelsGiveTheBuildsBits) {
  if (!wide_kernels_available()) GTEST_SKIP() << "no AVX-512 kernels on this CPU and build";
  const AeroModel model = GetParam();
  for (Integrator integrator : {Integrator::kRk4, Integrator::kEuler}) {
    for (StageLaw law : {StageLaw::kHeld, StageLaw::kGcas, StageLaw::kWaypoint}) {
      std::vector<double> bytes[2];
      std::vector<std::int32_t> status[2];
      for (int k = 0; k < 2; ++k) {
        F16BatchConfig cfg;
        cfg.n_env = 9;
        cfg.n_agent = 7;  // 63 aircraft: four blocks, the last with padding
        cfg.model = model;
        cfg.integrator = integrator;
        cfg.stage_law = law;
        cfg.isa = k == 0 ? KernelIsa::kWidest : KernelIsa::kBuild;
        cfg.limits.alpha_max_rad = 8.0 * kDegToRad;  // tight, so that the pulls and turns trip it
        cfg.limits.theta_max_rad = 12.0 * kDegToRad;
        cfg.limits.alt_max_ft = 16000.0;  // the fleet's highest trim (19 000 ft) is out at once
        F16Batch batch(cfg);
        ASSERT_EQ(batch.uses_wide_kernels(), k == 0);
        fill_fleet(batch, model);
        for (int i = 0; i < batch.size(); ++i) {
          batch.ref(kNzRef)[i] += (i % 4 == 0) ? 6.0 : 0.0;  // a quarter pull hard, into the envelope's limits
          if (law == StageLaw::kWaypoint) {
            batch.law(kLawTargetN)[i] = 3000.0 + 700.0 * (i % 5);
            batch.law(kLawTargetE)[i] = -2000.0 + 900.0 * (i % 7);
          }
        }
        for (int part = 0; part < 4; ++part) batch.step(integrator == Integrator::kRk4 ? 0.01 : 0.002, 60);
        batch.evaluate_outputs();
        for (int r = 0; r < kNumStates + kNumRefs + kNumOutputs; ++r) {
          const double* row = r < kNumStates ? batch.state(r)
                              : r < kNumStates + kNumRefs ? batch.ref(r - kNumStates)
                                                          : batch.output(r - kNumStates - kNumRefs);
          bytes[k].insert(bytes[k].end(), row, row + batch.size());
        }
        status[k].assign(batch.status(), batch.status() + batch.size());
      }
      const std::string what = std::string(integrator_name(integrator)) + ", " + stage_law_name(law);
      ASSERT_EQ(bytes[0].size(), bytes[1].size());
      EXPECT_EQ(0, std::memcmp(bytes[0].data(), bytes[1].data(), bytes[0].size() * sizeof(double))) << what;
      EXPECT_EQ(status[0], status[1]) << what;
      int flagged = 0;
      for (std::int32_t v : status[1]) flagged += v != kStatusOk;
      EXPECT_GT(flagged, 0) << what << ": no aircraft left the envelope, so the verdicts went unchecked";
    }
  }
}

INSTANTIATE_TEST_SUITE_P(BothModels, Batch, ::testing::Values(AeroModel::kMorelli, AeroModel::kStevens),
                         [](const auto& param_info) { return std::string(aero_model_name(param_info.param)); });

}  // namespace
}  // namespace f16race::dynamics
