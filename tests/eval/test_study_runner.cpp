// The study scheduler's words: cell labels and states, durations, and the progress line with
// its per-cell and whole-study ETAs.
#include <gtest/gtest.h>

#include <cmath>
#include <limits>

#include "eval/study_runner.hpp"

namespace f16race::eval {
namespace {

TEST(StudyRunner, CellLabelsAndStates) {
  StudyCell c;
  c.variant = "es_d3";
  c.seed = 3;
  c.dt_hl_s = 20.0;
  EXPECT_EQ(cell_label(c), "dt20/es_d3_s3");
  EXPECT_STREQ(cell_state_name(CellState::fresh), "to train");
  EXPECT_STREQ(cell_state_name(CellState::partial), "to resume");
  EXPECT_STREQ(cell_state_name(CellState::finished), "finished");
}

TEST(StudyRunner, DurationsInHoursOrMinutes) {
  EXPECT_EQ(hms(0.0), "0m00s");
  EXPECT_EQ(hms(187.4), "3m07s");
  EXPECT_EQ(hms(3600.0 + 5 * 60 + 29), "1h05m");
  EXPECT_EQ(hms(-1.0), "?");
  EXPECT_EQ(hms(std::nan("")), "?");
  EXPECT_EQ(hms(2e7), "?");
}

TEST(StudyRunner, ProgressLineWithoutRunningCells) {
  EXPECT_EQ(study_progress_line(2, 12, {}, 1000.0), "study: 2/12 cells done | study ETA ? (trainings)\n");
}

TEST(StudyRunner, ProgressLineEtasFromEachCellsRate) {
  // 400 of 1000 steps, 100 of them in 10 s here: 10 steps/s, 600 left -> 1m00s. The other has
  // made no progress here: no rate, no ETA. The study: 600 + 1000 + 500 queued at 10 steps/s.
  const std::vector<CellProgress> running{{"dt8/es_s1", 400, 300, 1000, 10.0}, {"dt8/es_d1_s1", 0, 0, 1000, 10.0}};
  EXPECT_EQ(study_progress_line(1, 4, running, 500.0),
            "study: 1/4 cells done | dt8/es_s1 40% ETA 1m00s | dt8/es_d1_s1 0% ETA ? | study ETA 3m30s (trainings)\n");
}

// A cell whose run has reached its budget while its tail members still train is not done: with
// two members of a 1000-step run's last 500, 1000 of its 2000 steps, at 10 steps/s 1m40s to go.
TEST(StudyRunner, ProgressLineCountsTheTailMembers) {
  const std::vector<CellProgress> running{{"dt8/es_d2_s1", 1000, 0, 2000, 100.0}};
  EXPECT_EQ(study_progress_line(0, 1, running, 0.0),
            "study: 0/1 cells done | dt8/es_d2_s1 50% ETA 1m40s | study ETA 1m40s (trainings)\n");
}

}  // namespace
}  // namespace f16race::eval
