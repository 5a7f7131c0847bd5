// The observation spec (race/observation_spec.hpp) is the one list of observation entries: the
// env's buffers have its widths, its fields tile each row, and docs/race.md's tables say what
// it says, row for row.
#include <gtest/gtest.h>

#include <fstream>
#include <iterator>
#include <string>
#include <utility>
#include <vector>

#include "race/observation_spec.hpp"
#include "race/race_config.hpp"
#include "race/race_env.hpp"

namespace f16race::race {
namespace {

std::string read_docs() {
  // The test data folder is tests/data; the docs are two levels up.
  std::ifstream in(std::string(F16RACE_TEST_DATA_DIR) + "/../../docs/race.md");
  return std::string(std::istreambuf_iterator<char>(in), {});
}

template <std::size_t N>
void expect_rows(const std::string& docs, const ObsField (&fields)[N], int base, const char* what) {
  for (const ObsField& f : fields) {
    std::string label = std::to_string(base + f.offset);
    if (f.width > 1) label += "-" + std::to_string(base + f.offset + f.width - 1);
    const std::string row = "| " + label + " | " + f.meaning + " |";
    EXPECT_NE(docs.find(row), std::string::npos) << what << ": docs/race.md lacks the row " << row;
  }
}

TEST(ObservationSpec, DocsTablesMatchTheSpec) {
  const std::string docs = read_docs();
  ASSERT_GT(docs.size(), 1000u) << "docs/race.md not found";
  expect_rows(docs, kEgoFields, 0, "ego");
  expect_rows(docs, kGoalFields, 0, "goal");
  expect_rows(docs, kAdoFields, 0, "ado");
  expect_rows(docs, kPreviewFields, 0, "preview point");
  // The tail is documented at the default preview length.
  expect_rows(docs, kTaskTailFields, kPreviewWidth * RaceConfig{}.preview_points, "task tail");
  EXPECT_NE(docs.find("| ego (kEgoDim = " + std::to_string(kEgoDim) + ")"), std::string::npos);
  EXPECT_NE(docs.find("| ado (kAdoDim = " + std::to_string(kAdoDim) + ")"), std::string::npos);
}

TEST(ObservationSpec, EnvBuffersHaveTheSpecsWidths) {
  RaceConfig c;
  c.n_env = 2;
  c.team_size = 2;
  c.preview_points = 4;
  RaceEnv env(c);
  EXPECT_EQ(env.task_dim(), kPreviewWidth * 4 + kTaskTailWidth);
  EXPECT_EQ(task_dim(c), env.task_dim());
  EXPECT_EQ(env.ado_dim(), kAdoDim);
  // After a reset the entries sit where the spec says: speed, unit sin/cos pairs, full time left.
  env.reset();
  const int n = c.n_env * env.n_agent();
  for (int i = 0; i < n; ++i) {
    const float* ego = env.obs_ego() + static_cast<std::size_t>(i) * kEgoDim;
    EXPECT_NEAR(ego[kEgoVt], c.start_speed_ftps / 1000.0, 1e-4) << "aircraft " << i;
    for (int k = 0; k < 5; ++k) {  // sin^2 + cos^2 = 1 for every angle pair
      const float s = ego[kEgoAttitudeTrig + 2 * k], co = ego[kEgoAttitudeTrig + 2 * k + 1];
      EXPECT_NEAR(s * s + co * co, 1.0f, 1e-5f) << "aircraft " << i << " angle " << k;
    }
    const float* task = env.obs_task() + static_cast<std::size_t>(i) * env.task_dim();
    const float* tail = task + kPreviewWidth * c.preview_points;
    EXPECT_NEAR(tail[kTaskTimeLeft], 1.0f, 1e-6f);  // race time 0
    EXPECT_GE(tail[kTaskCenterDistance], 0.0f);
    for (int p = 0; p < c.preview_points; ++p) {
      const float* pp = task + kPreviewWidth * p;
      EXPECT_NEAR(pp[kPreviewAzimuth] * pp[kPreviewAzimuth] + pp[kPreviewAzimuth + 1] * pp[kPreviewAzimuth + 1], 1.0f,
                  1e-4f);
      EXPECT_GT(pp[kPreviewRadius], 0.0f);
    }
  }
}

}  // namespace
}  // namespace f16race::race
