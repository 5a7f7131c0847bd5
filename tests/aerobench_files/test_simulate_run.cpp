// `f16race simulate` without its command line: conflicting sources refused, a scripted run, an
// autopilot batch and a derivative file written, each with the outcome the command prints.
#include <gtest/gtest.h>

#include <fstream>
#include <sstream>
#include <string>

#include "aerobench_files/simulate_run.hpp"
#include "io/csv_table.hpp"
#include "io/input_error.hpp"
#include "support/temp_paths.hpp"

namespace f16race::aerobench_files {
namespace {

const std::string kData = F16RACE_TEST_DATA_DIR;

TEST(SimulateRun, ConflictingSourcesAreRefused) {
  SimulateRequest r;
  r.reference = "a.csv";
  r.commands = "b.csv";
  EXPECT_THROW(check_sources(r), io::InputError);
  r.commands.clear();
  r.init = "c.csv";
  EXPECT_THROW(check_sources(r), io::InputError);
  r.init.clear();
  EXPECT_NO_THROW(check_sources(r));
  r.derivatives = "d.csv";
  EXPECT_THROW(check_sources(r), io::InputError);
  SimulateRequest a;
  a.autopilot = "gcas";
  a.commands = "b.csv";
  EXPECT_THROW(check_sources(a), io::InputError);
}

TEST(SimulateRun, ScriptedTrimRun) {
  SimulateRequest r;
  r.duration_s = 1.0;
  r.sample_s = 0.1;
  r.out = test_support::fresh_temp_path("simulate_run_trim.csv");
  const SimulateOutcome o = simulate_to_file(r);
  ASSERT_FALSE(o.is_batch);
  EXPECT_EQ(o.trajectory.samples, 11u);
  EXPECT_FALSE(o.trajectory.autopilot);
  EXPECT_FALSE(o.trajectory.has_reference);
  EXPECT_TRUE(o.trajectory.comparison.empty());
  EXPECT_EQ(io::CsvTable::read(r.out).rows(), 11u);
  r.model = "boeing";
  EXPECT_THROW(simulate_to_file(r), io::InputError);
}

TEST(SimulateRun, AutopilotBatchOfTwoStarts) {
  std::ifstream in(kData + "/init_waypoint_example.csv");
  std::string header, row;
  std::getline(in, header);
  std::getline(in, row);
  const std::string init = test_support::fresh_temp_path("simulate_run_init.csv");
  std::ofstream(init) << header << "\n" << row << "\n" << row << "\n";
  SimulateRequest r;
  r.autopilot = "waypoint";
  r.waypoints = kData + "/waypoints_aerobench_example.csv";
  r.init = init;
  r.duration_s = 2.0;
  r.out = test_support::fresh_temp_path("simulate_run_batch.csv");
  const SimulateOutcome o = simulate_to_file(r);
  ASSERT_TRUE(o.is_batch);
  EXPECT_EQ(o.batch.aircraft, 2u);
  EXPECT_EQ(o.batch.failed, 0);
  EXPECT_EQ(o.batch.below_ground, 0);
  EXPECT_NEAR(o.batch.lowest_alt_ft, 3800.0, 200.0);
  EXPECT_EQ(io::CsvTable::read(r.out).rows(), 2u);
  r.compare = true;  // nothing to compare a batch with
  EXPECT_THROW(simulate_to_file(r), io::InputError);
}

TEST(SimulateRun, DerivativesMatchAeroBench) {
  SimulateRequest r;
  r.derivatives = kData + "/deriv_plant_morelli.csv";
  r.compare = true;
  r.out = test_support::fresh_temp_path("simulate_run_deriv.csv");
  const DerivativesOutcome d = derivatives_to_file(r);
  EXPECT_GT(d.points, 0u);
  EXPECT_FALSE(d.closed_loop);
  ASSERT_FALSE(d.comparison.empty());
  for (const ColumnDiff& c : d.comparison) EXPECT_LT(c.worst, 1e-6) << c.column;
}

}  // namespace
}  // namespace f16race::aerobench_files
