// Trim against the values the AeroBench reference README tabulates (solved there with scipy on
// AeroBench's own subf16_model), and against row 0 of the a_trim_level files.
#include <gtest/gtest.h>

#include <cmath>
#include <stdexcept>

#include "dynamics/trim.hpp"
#include "reference_data.hpp"

namespace f16race::dynamics {
namespace {

struct Expected {
  AeroModel model;
  double alpha, elevator, throttle, pow, int_nz, nz_ref0, throttle_delta0;
};

class Trim : public ::testing::TestWithParam<Expected> {};

TEST_P(Trim, ReproducesAeroBenchTrimAt540FtpsAnd5000Ft) {
  const Expected e = GetParam();
  TrimRequest req;
  req.model = e.model;
  req.vt_ftps = 540.0;
  req.alt_ft = 5000.0;
  const TrimResult t = trim_level_flight(req);
  EXPECT_NEAR(t.alpha_rad, e.alpha, 1e-10);
  EXPECT_NEAR(t.elevator_deg, e.elevator, 1e-8);
  EXPECT_NEAR(t.throttle, e.throttle, 1e-10);
  EXPECT_NEAR(t.x0[kPow], e.pow, 1e-8);
  EXPECT_NEAR(t.x0[kIntNz], e.int_nz, 1e-9);
  EXPECT_NEAR(t.u_ref[kNzRef], e.nz_ref0, 1e-12);
  EXPECT_NEAR(t.u_ref[kThrottleDelta], e.throttle_delta0, 1e-10);
  EXPECT_LT(t.residual, 1e-9);
  // The reference run starts from exactly this state.
  const io::CsvTable ref = test::load_reference(std::string("a_trim_level_") + aero_model_name(e.model) + ".csv");
  for (int s = 0; s < kNumStates; ++s)
    EXPECT_NEAR(t.x0[s], ref.numeric(kStateNames[s]).front(), 1e-8) << kStateNames[s];
}

INSTANTIATE_TEST_SUITE_P(
    BothModels, Trim,
    ::testing::Values(Expected{AeroModel::kStevens, 0.03716420496303573, -0.7575935899333787, 0.15949768750046905,
                               10.35777982628046, 0.006824666500570234, -0.0006905095833837915, 0.01999768750046904},
                      Expected{AeroModel::kMorelli, 0.025484745411115922, -1.8085355008756157, 0.13512007986222455,
                               8.774697986252862, 0.026998609776051865, -0.000324718549123415,
                               -0.004379920137775467}),
    [](const auto& param_info) { return std::string(aero_model_name(param_info.param.model)); });

TEST(TrimErrors, ImpossibleConditionIsRefusedWithTheRequestInTheMessage) {
  TrimRequest req;
  req.vt_ftps = 120.0;  // far below stall speed at 40000 ft
  req.alt_ft = 40000.0;
  try {
    trim_level_flight(req);
    FAIL() << "expected an exception";
  } catch (const std::runtime_error& e) {
    EXPECT_NE(std::string(e.what()).find("vt=120"), std::string::npos) << e.what();
  }
}

}  // namespace
}  // namespace f16race::dynamics
