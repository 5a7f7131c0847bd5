// A figure counts as drawn only when gnuplot exited 0 and left a whole image: an empty, cut or
// foreign file is reported in one line and never left under the figure's name.
#include <gtest/gtest.h>

#include <filesystem>
#include <fstream>
#include <string>

#include "io/atomic_file.hpp"
#include "io/plot.hpp"
#include "support/temp_paths.hpp"

namespace f16race::io {
namespace {

namespace fs = std::filesystem;

const std::string kSignature("\x89PNG\r\n\x1a\n", 8);
const std::string kIend("\0\0\0\0IEND\xae\x42\x60\x82", 12);

std::string fresh_dir(const std::string& name) {
  const std::string p = test_support::fresh_temp_path("plot_" + name);
  fs::create_directories(p);
  return p;
}

TEST(PlotImage, AcceptsOnlyAWholePng) {
  const std::string d = fresh_dir("check");
  write_file_atomic(d + "/whole.png", kSignature + std::string(100, 'x') + kIend);
  write_file_atomic(d + "/empty.png", "");
  write_file_atomic(d + "/cut.png", kSignature + std::string(100, 'x'));
  write_file_atomic(d + "/text.png", "not an image at all, but long enough");
  write_file_atomic(d + "/whole.svg", "<svg>\n</svg>\n");
  write_file_atomic(d + "/cut.svg", "<svg>\n<path");
  EXPECT_EQ(image_problem(d + "/whole.png"), "");
  EXPECT_EQ(image_problem(d + "/missing.png"), "no image was written");
  EXPECT_EQ(image_problem(d + "/empty.png"), "the image is empty");
  EXPECT_EQ(image_problem(d + "/cut.png"), "the PNG ends before its IEND chunk (cut short)");
  EXPECT_EQ(image_problem(d + "/text.png"), "the file is not a PNG");
  EXPECT_EQ(image_problem(d + "/whole.svg"), "");
  EXPECT_EQ(image_problem(d + "/cut.svg"), "the SVG ends before </svg> (cut short)");
}

PlotSpec line_spec(const std::string& dir, const std::string& data, bool atomic) {
  PlotSpec spec;
  spec.output = dir + "/fig.png";
  spec.width_px = 320;
  spec.height_px = 240;
  spec.atomic_output = atomic;
  PlotPanel p{"t", "x", "y", {}, ""};
  p.series.push_back({data, "1:2", "lines", "", ""});
  spec.panels = {p};
  return spec;
}

TEST(PlotImage, AFailedGnuplotLeavesNoImageUnderTheFiguresName) {
  if (!gnuplot_available()) GTEST_SKIP() << "gnuplot not installed";
  for (const bool atomic : {false, true}) {
    const std::string d = fresh_dir(atomic ? "fail_atomic" : "fail_direct");
    write_file_atomic(d + "/data.csv", "x,y\n0,0\n1,1\n");
    std::string msg;
    ASSERT_TRUE(render_plot(line_spec(d, "data.csv", atomic), d + "/fig.gp", &msg)) << msg;
    EXPECT_EQ(image_problem(d + "/fig.png"), "");
    // A series on a missing column: gnuplot exits non-zero after opening its output.
    PlotSpec bad = line_spec(d, "data.csv", atomic);
    bad.panels[0].series[0].using_expr = "1:9";
    EXPECT_FALSE(render_plot(bad, d + "/fig.gp", &msg));
    EXPECT_EQ(msg.find('\n'), std::string::npos) << msg;
    EXPECT_EQ(msg.rfind("gnuplot failed on " + d + "/fig.gp: ", 0), 0u) << msg;
    if (atomic) EXPECT_EQ(image_problem(d + "/fig.png"), "") << "the earlier image was not kept";
    else EXPECT_FALSE(fs::exists(d + "/fig.png")) << "a failed image was left under its name";
    for (const auto& e : fs::directory_iterator(d))
      EXPECT_EQ(e.path().filename().string().find(".tmp."), std::string::npos) << e.path();
  }
}

}  // namespace
}  // namespace f16race::io
