// Single-point checks against AeroBench: every row of deriv_plant_* and deriv_closed_loop_*,
// every output and intermediate the files give, to 1e-9 * max(1, |ref|).
#include <gtest/gtest.h>

#include <cmath>
#include <string>

#include "dynamics/model_probe.hpp"
#include "reference_data.hpp"

namespace f16race::dynamics {
namespace {

constexpr double kTol = 1e-9;

struct Outcome {
  int compared = 0;
  double worst = 0.0;
  std::string worst_where;
};

void check(const io::CsvTable& ref, std::size_t row, const std::vector<NamedValue>& values, Outcome* o) {
  for (const NamedValue& v : values) {
    if (!ref.has_column(v.name)) continue;
    const double theirs = ref.numeric(v.name)[row];
    const double err = std::fabs(v.value - theirs) / std::max(1.0, std::fabs(theirs));
    ++o->compared;
    if (!(err <= o->worst)) {
      o->worst = err;
      o->worst_where = v.name + " row " + std::to_string(row) + " (" + ref.cell(row, 0) + ")";
    }
    EXPECT_LE(err, kTol) << ref.source() << " row " << row << " column " << v.name << ": ours " << v.value
                         << " AeroBench " << theirs;
  }
}

class PlantDerivatives : public ::testing::TestWithParam<AeroModel> {};

TEST_P(PlantDerivatives, MatchAeroBenchAtEveryPoint) {
  const AeroModel model = GetParam();
  const io::CsvTable ref = test::load_reference(std::string("deriv_plant_") + aero_model_name(model) + ".csv");
  ASSERT_EQ(ref.rows(), 20u);
  Outcome o;
  for (std::size_t r = 0; r < ref.rows(); ++r) {
    double x[kNumPlantStates];
    for (int s = 0; s < kNumPlantStates; ++s) x[s] = ref.numeric(kStateNames[s])[r];
    const SurfaceCommands u{ref.numeric("throttle")[r], ref.numeric("elevator_deg")[r],
                            ref.numeric("aileron_deg")[r], ref.numeric("rudder_deg")[r]};
    check(ref, r, probe_plant(model, x, u), &o);
  }
  // 13 xdot + 4 outputs + 6 intermediates + 9 damping + 6 or 10 coefficients, on 20 rows.
  const int per_row = model == AeroModel::kStevens ? 42 : 38;
  EXPECT_EQ(o.compared, 20 * per_row);
  std::printf("[ %s plant ] %d values, worst relative error %.2e at %s\n", aero_model_name(model), o.compared,
              o.worst, o.worst_where.c_str());
}

class ClosedLoopDerivatives : public ::testing::TestWithParam<AeroModel> {};

TEST_P(ClosedLoopDerivatives, MatchAeroBenchAtEveryPoint) {
  const AeroModel model = GetParam();
  const io::CsvTable ref = test::load_reference(std::string("deriv_closed_loop_") + aero_model_name(model) + ".csv");
  ASSERT_EQ(ref.rows(), 20u);
  Outcome o;
  for (std::size_t r = 0; r < ref.rows(); ++r) {
    StateVector x;
    RefVector u;
    for (int s = 0; s < kNumStates; ++s) x[s] = ref.numeric(kStateNames[s])[r];
    for (int k = 0; k < kNumRefs; ++k) u[k] = ref.numeric(kRefNames[k])[r];
    check(ref, r, probe_closed_loop(model, x, u), &o);
  }
  EXPECT_EQ(o.compared, 20 * (4 + 16 + 3));
  std::printf("[ %s closed loop ] %d values, worst relative error %.2e at %s\n", aero_model_name(model),
              o.compared, o.worst, o.worst_where.c_str());
}

INSTANTIATE_TEST_SUITE_P(BothModels, PlantDerivatives, ::testing::Values(AeroModel::kMorelli, AeroModel::kStevens),
                         [](const auto& param_info) { return std::string(aero_model_name(param_info.param)); });
INSTANTIATE_TEST_SUITE_P(BothModels, ClosedLoopDerivatives,
                         ::testing::Values(AeroModel::kMorelli, AeroModel::kStevens),
                         [](const auto& param_info) { return std::string(aero_model_name(param_info.param)); });

}  // namespace
}  // namespace f16race::dynamics
