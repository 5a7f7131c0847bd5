// Whole trajectories against AeroBench (its RK45 at 1e-12 tolerance): our fixed-step RK4 at
// dt = 0.01 s, references replayed from the files, must stay within the tolerances below.
#include <gtest/gtest.h>

#include <cmath>
#include <string>

#include "aerobench_files/aerobench_csv.hpp"
#include "dynamics/reference_replay.hpp"
#include "reference_data.hpp"

namespace f16race::dynamics {
namespace {

struct Case {
  const char* scenario;
  AeroModel model;
  double scale;  // tolerance multiplier: 10 for the GCAS run replayed from sampled references
  RefInterp interp;
};

struct Errors {
  double vt = 0, angle = 0, pos = 0;
};

Errors replay_and_compare(const Case& c) {
  const io::CsvTable ref = test::load_reference(std::string(c.scenario) + "_" + aero_model_name(c.model) + ".csv");
  aerobench_files::ReplaySettings settings;
  settings.model = c.model;
  settings.integrator = Integrator::kRk4;
  settings.interp = c.interp;
  settings.dt_s = 0.01;
  // The file's `mode` column becomes reference segments (jumps are never interpolated across).
  const ReplayRequest req = aerobench_files::request_from_reference(ref, settings);
  const ReplayResult res = replay_references(req);
  EXPECT_EQ(res.status, kStatusOk);
  EXPECT_EQ(res.samples.size(), ref.rows());
  Errors e;
  for (int s = 0; s < kNumStates; ++s) {
    const std::vector<double> theirs = ref.numeric(kStateNames[s]);
    double worst = 0.0;
    for (std::size_t k = 0; k < res.samples.size(); ++k) worst = std::fmax(worst, std::fabs(res.samples[k].x[s] - theirs[k]));
    if (s == kVt) e.vt = worst;
    if (s >= kAlpha && s <= kPsi) e.angle = std::fmax(e.angle, worst);
    if (s >= kPn && s <= kAlt) e.pos = std::fmax(e.pos, worst);
  }
  return e;
}

class Trajectory : public ::testing::TestWithParam<Case> {};

TEST_P(Trajectory, StaysWithinToleranceOfAeroBench) {
  const Case c = GetParam();
  const Errors e = replay_and_compare(c);
  std::printf("[ %s %s ] max error: vt %.2e ft/s, angles %.2e rad, position %.2e ft\n", c.scenario,
              aero_model_name(c.model), e.vt, e.angle, e.pos);
  EXPECT_LT(e.vt, 0.05 * c.scale);
  EXPECT_LT(e.angle, 1e-4 * c.scale);
  EXPECT_LT(e.pos, 1.0 * c.scale);
}

INSTANTIATE_TEST_SUITE_P(
    AeroBench, Trajectory,
    ::testing::Values(Case{"a0_xequil_zero_cmd", AeroModel::kMorelli, 1, RefInterp::kHold},
                      Case{"a0_xequil_zero_cmd", AeroModel::kStevens, 1, RefInterp::kHold},
                      Case{"a_trim_level", AeroModel::kMorelli, 1, RefInterp::kHold},
                      Case{"a_trim_level", AeroModel::kStevens, 1, RefInterp::kHold},
                      Case{"b_nz_pulse", AeroModel::kMorelli, 1, RefInterp::kHold},
                      Case{"b_nz_pulse", AeroModel::kStevens, 1, RefInterp::kHold},
                      Case{"c_ps_doublet", AeroModel::kMorelli, 1, RefInterp::kHold},
                      Case{"c_ps_doublet", AeroModel::kStevens, 1, RefInterp::kHold},
                      Case{"f_gcas", AeroModel::kMorelli, 10, RefInterp::kLinear},
                      Case{"f_gcas", AeroModel::kStevens, 10, RefInterp::kLinear}),
    [](const auto& param_info) { return std::string(param_info.param.scenario) + "_" + aero_model_name(param_info.param.model); });

}  // namespace
}  // namespace f16race::dynamics
