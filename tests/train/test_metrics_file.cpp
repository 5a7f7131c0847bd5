// metrics.csv read back at a resume: line ends and byte-order marks of other tools, an older
// build's header, rows past the checkpoint, and files that are not metrics.csv.
#include <gtest/gtest.h>

#include <algorithm>
#include <stdexcept>
#include <string>

#include "train/metrics_file.hpp"

namespace f16race::train {
namespace {

std::string error_of(const std::string& text, std::int64_t updates) {
  try {
    metrics_kept_up_to(text, updates, "R/metrics.csv");
  } catch (const std::runtime_error& e) {
    return e.what();
  }
  return "";
}

TEST(MetricsFile, KeepsTheRowsUpToTheCheckpointWithLfEnds) {
  const std::string h = metrics_header_line();
  const std::string lf = h + "\n1,a\n2,b\n3,c\n";
  EXPECT_EQ(metrics_kept_up_to(lf, 2, "m"), h + "\n1,a\n2,b\n");
  // A byte-order mark and CRLF (a spreadsheet's save), or old Mac CR ends: the same rows.
  EXPECT_EQ(metrics_kept_up_to("\xEF\xBB\xBF" + h + "\r\n1,a\r\n2,b\r\n3,c\r\n", 2, "m"), h + "\n1,a\n2,b\n");
  EXPECT_EQ(metrics_kept_up_to(h + "\r1,a\r2,b\r3,c", 2, "m"), h + "\n1,a\n2,b\n");
  EXPECT_EQ(metrics_kept_up_to("", 5, "m"), h + "\n");  // an empty file: the header alone
}

TEST(MetricsFile, AnOlderHeaderIsExtendedAndItsRowsPadded) {
  const std::string h = metrics_header_line();
  const std::string old = h.substr(0, h.find(",wall_s"));  // update,phase_hl,env_steps
  const std::size_t missing = static_cast<std::size_t>(std::count(h.begin(), h.end(), ',') - 2);
  EXPECT_EQ(metrics_kept_up_to(old + "\n1,0,32\n", 1, "m"), h + "\n1,0,32" + std::string(missing, ',') + "\n");
}

TEST(MetricsFile, RowsAndHeadersThatAreNotMetricsAreRefusedNamingTheLine) {
  const std::string h = metrics_header_line();
  EXPECT_NE(error_of(h + "\n1,a\nabc,b\n", 5).find("R/metrics.csv:3: 'abc' is not an update count"), std::string::npos);
  EXPECT_NE(error_of(h + "\n,a\n", 5).find("R/metrics.csv:2:"), std::string::npos);
  EXPECT_NE(error_of(h + "\n99999999999999999999,a\n", 5).find("R/metrics.csv:2:"), std::string::npos);
  EXPECT_NE(error_of(h + "\n-1,a\n", 5).find("R/metrics.csv:2:"), std::string::npos);
  EXPECT_NE(error_of("time,value\n1,2\n", 5).find("R/metrics.csv:1: not the header of f16race's metrics.csv"),
            std::string::npos);
  EXPECT_NE(error_of(std::string("\x01\xff\xfe garbage", 11), 5).find("R/metrics.csv:1:"), std::string::npos);
}

}  // namespace
}  // namespace f16race::train
