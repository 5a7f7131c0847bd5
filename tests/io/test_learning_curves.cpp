// Learning-curve figure from a run's metrics.csv: running means in curves_data.csv, tolerance of
// missing columns and empty/nan cells, errors naming the file, and the PNG through gnuplot.
#include "io/learning_curves.hpp"

#include <gtest/gtest.h>

#include <chrono>
#include <cmath>
#include <cstdlib>
#include <filesystem>
#include <fstream>
#include <functional>
#include <sstream>
#include <stdexcept>
#include <string>
#include <thread>
#include <vector>

#include <unistd.h>

#include "io/csv_table.hpp"
#include "io/plot.hpp"

namespace fs = std::filesystem;
using f16race::io::CsvTable;
using f16race::io::gnuplot_available;
using f16race::io::kLearningCurveWindow;
using f16race::io::write_learning_curves;

namespace {

const std::vector<std::string> kAllColumns = {
    "update", "phase_hl", "env_steps", "wall_s", "samples_per_s", "ll_return", "hl_return", "goal_dist_ft",
    "winrate", "finish_rate", "races", "term_collision", "term_altitude", "term_load", "term_turn_rate",
    "term_tube", "term_simulator", "policy_loss", "value_loss", "entropy", "approx_kl", "lr", "es_loss",
    "q_mean", "epsilon", "hl_grad_steps", "es_end_atom_share", "es_huber_share", "q_spread", "greedy_entropy",
    "off_center_share", "airspeed_ftps", "middle_share_x", "middle_share_y", "middle_share_z"};

// Cell text of column `name` in row r; columns not given here are 0.
using CellFn = std::function<std::string(const std::string& name, int r)>;

std::string metrics_text(const std::vector<std::string>& columns, int rows, const CellFn& cell) {
  std::string s;
  for (std::size_t c = 0; c < columns.size(); ++c) s += (c ? "," : "") + columns[c];
  s += "\n";
  for (int r = 0; r < rows; ++r) {
    for (std::size_t c = 0; c < columns.size(); ++c) s += (c ? "," : "") + cell(columns[c], r);
    s += "\n";
  }
  return s;
}

// Rows 0..9 LL phase, 10..19 HL, 20..29 LL, 30..39 HL. finish_rate = r / 100, ll_return = r except
// an empty cell at row 5 and nan at row 6, es_end_atom_share = r / 100 (also on LL rows, where the
// figure must ignore it), env_steps = 1000 * (r + 1).
std::string synthetic_cell(const std::string& name, int r) {
  const bool hl = (r / 10) % 2 == 1;
  if (name == "update") return std::to_string(r);
  if (name == "phase_hl") return hl ? "1" : "0";
  if (name == "env_steps") return std::to_string(1000 * (r + 1));
  if (name == "finish_rate" || name == "es_end_atom_share") return f16race::io::format_double(r / 100.0);
  if (name == "ll_return") return r == 5 ? "" : r == 6 ? "nan" : std::to_string(r);
  if (name == "winrate") return "0.5";
  if (name == "q_spread") return "2";
  return "0";
}

// Mean of v[k] over the last `window` indices k <= i present in `valid`.
double expected_mean(const std::vector<int>& valid, int i, const std::function<double(int)>& v) {
  std::vector<int> upto;
  for (int k : valid)
    if (k <= i) upto.push_back(k);
  const std::size_t n = std::min<std::size_t>(upto.size(), kLearningCurveWindow);
  double sum = 0.0;
  for (std::size_t k = upto.size() - n; k < upto.size(); ++k) sum += v(upto[k]);
  return sum / static_cast<double>(n);
}

class LearningCurvesTest : public ::testing::Test {
 protected:
  void SetUp() override {
    const auto* info = ::testing::UnitTest::GetInstance()->current_test_info();
    dir_ = fs::temp_directory_path() / ("f16race_curves_" + std::to_string(::getpid()) + "_" + info->name());
    fs::remove_all(dir_);
    fs::create_directories(dir_);
  }
  void TearDown() override { fs::remove_all(dir_); }

  void write_metrics(const std::string& text) const {
    std::ofstream out(dir_ / "metrics.csv", std::ios::binary);
    out << text;
  }
  static std::string slurp(const fs::path& p) {
    std::ifstream in(p, std::ios::binary);
    std::ostringstream ss;
    ss << in.rdbuf();
    return ss.str();
  }
  // write_learning_curves must throw a runtime_error; returns its message.
  std::string error_of() const {
    try {
      std::string msg;
      write_learning_curves(dir_.string(), &msg);
    } catch (const std::runtime_error& e) {
      return e.what();
    }
    ADD_FAILURE() << "expected std::runtime_error";
    return "";
  }

  fs::path dir_;
};

TEST_F(LearningCurvesTest, SmoothedDataHoldsRunningMeans) {
  constexpr int kRows = 40;
  write_metrics(metrics_text(kAllColumns, kRows, synthetic_cell));
  std::string msg;
  write_learning_curves(dir_.string(), &msg);  // the figure itself is checked below
  const CsvTable data = CsvTable::read((dir_ / "curves_data.csv").string());
  ASSERT_EQ(data.rows(), static_cast<std::size_t>(kRows));
  const auto x = data.numeric("env_steps_M");
  EXPECT_DOUBLE_EQ(x[0], 0.001);
  EXPECT_DOUBLE_EQ(x[kRows - 1], 0.04);

  // finish_rate: every row valid.
  std::vector<int> all;
  for (int r = 0; r < kRows; ++r) all.push_back(r);
  const auto fin = data.numeric("finish_rate_smooth");
  const auto fin_raw = data.numeric("finish_rate");
  for (int r = 0; r < kRows; ++r) {
    EXPECT_DOUBLE_EQ(fin_raw[r], r / 100.0) << "row " << r;
    EXPECT_NEAR(fin[r], expected_mean(all, r, [](int k) { return k / 100.0; }), 1e-12) << "row " << r;
  }
  EXPECT_NEAR(fin[0], 0.0, 1e-12);
  EXPECT_NEAR(fin[3], 0.015, 1e-12);               // (0 + 1 + 2 + 3) / 4 / 100
  EXPECT_NEAR(fin[kRows - 1], 0.295, 1e-12);       // rows 20..39
  // The constant winrate stays constant.
  for (double v : data.numeric("winrate_smooth")) EXPECT_DOUBLE_EQ(v, 0.5);

  // ll_return: the empty (row 5) and nan (row 6) cells are skipped, not zeros.
  std::vector<int> ll_valid;
  for (int r = 0; r < kRows; ++r)
    if (r != 5 && r != 6) ll_valid.push_back(r);
  const auto ll = data.numeric("ll_return_smooth");
  const auto ll_raw = data.numeric("ll_return");
  EXPECT_TRUE(std::isnan(ll_raw[5]));
  EXPECT_TRUE(std::isnan(ll_raw[6]));
  EXPECT_TRUE(std::isnan(ll[5]));
  EXPECT_TRUE(std::isnan(ll[6]));
  EXPECT_NEAR(ll[7], (0 + 1 + 2 + 3 + 4 + 7) / 6.0, 1e-12);
  // Row 25: the last 20 valid rows are 4, 7..25.
  EXPECT_NEAR(ll[25], (4.0 + (7 + 25) * 19 / 2.0) / 20.0, 1e-12);
  for (int r : ll_valid) EXPECT_NEAR(ll[r], expected_mean(ll_valid, r, [](int k) { return k; }), 1e-12) << "row " << r;

  // es_end_atom_share: HL-phase rows only (10..19, 30..39), smoothed over those rows alone.
  std::vector<int> hl_rows;
  for (int r = 0; r < kRows; ++r)
    if ((r / 10) % 2 == 1) hl_rows.push_back(r);
  const auto es = data.numeric("es_end_atom_share_smooth");
  const auto es_raw = data.numeric("es_end_atom_share");
  for (int r = 0; r < kRows; ++r) {
    const bool hl = (r / 10) % 2 == 1;
    EXPECT_EQ(std::isnan(es_raw[r]), !hl) << "row " << r;
    EXPECT_EQ(std::isnan(es[r]), !hl) << "row " << r;
  }
  EXPECT_NEAR(es[10], 0.10, 1e-12);
  EXPECT_NEAR(es[19], 0.145, 1e-12);  // rows 10..19
  EXPECT_NEAR(es[30], (0.10 + 0.19) * 10 / 2 / 11 + 0.30 / 11, 1e-12);  // rows 10..19 and 30
  EXPECT_NEAR(es[39], 0.245, 1e-12);  // rows 10..19, 30..39
  for (int r : hl_rows) EXPECT_NEAR(es[r], expected_mean(hl_rows, r, [](int k) { return k / 100.0; }), 1e-12);

  // The script reads the data file and keeps the final image name for runs by hand.
  const std::string gp = slurp(dir_ / "curves.gp");
  EXPECT_NE(gp.find("'curves_data.csv'"), std::string::npos);
  EXPECT_NE(gp.find("'curves.png'"), std::string::npos);
  EXPECT_NE(gp.find("size 1600,1000"), std::string::npos);
  EXPECT_NE(gp.find(dir_.filename().string()), std::string::npos) << "title: the run folder name";
}

TEST_F(LearningCurvesTest, MissingOptionalColumnsAreSkipped) {
  // Before the new diagnostics: no hl_grad_steps, es_*_share, q_spread, greedy_entropy,
  // off_center_share; hl_return present but all nan.
  std::vector<std::string> old_columns;
  for (const std::string& c : kAllColumns)
    if (c.find("share") == std::string::npos && c != "q_spread" && c != "greedy_entropy" && c != "hl_grad_steps")
      old_columns.push_back(c);
  write_metrics(metrics_text(old_columns, 25, [](const std::string& name, int r) {
    return name == "hl_return" ? std::string("nan") : synthetic_cell(name, r);
  }));
  std::string msg;
  ASSERT_NO_THROW(write_learning_curves(dir_.string(), &msg));
  const CsvTable data = CsvTable::read((dir_ / "curves_data.csv").string());
  EXPECT_TRUE(data.has_column("finish_rate_smooth"));
  EXPECT_TRUE(data.has_column("ll_return_smooth"));
  for (const char* gone : {"q_spread", "greedy_entropy", "off_center_share", "middle_share_y", "es_end_atom_share", "es_huber_share",
                           "hl_return"}) {
    EXPECT_FALSE(data.has_column(gone)) << gone;
    EXPECT_FALSE(data.has_column(std::string(gone) + "_smooth")) << gone;
  }
  // Their panels stay, empty and saying so.
  const std::string gp = slurp(dir_ / "curves.gp");
  EXPECT_NE(gp.find("'(q_spread, greedy_entropy, off_center_share, middle_share_x, middle_share_y, middle_share_z)'"),
            std::string::npos);
  EXPECT_NE(gp.find("'(hl_return)'"), std::string::npos);
  if (gnuplot_available()) {
    EXPECT_TRUE(fs::exists(dir_ / "curves.png")) << msg;
  }
}

TEST_F(LearningCurvesTest, MalformedCsvThrowsNamingTheFile) {
  const std::string path = (dir_ / "metrics.csv").string();
  EXPECT_NE(error_of().find(path), std::string::npos) << "missing file";

  std::string text = metrics_text(kAllColumns, 5, synthetic_cell);
  const auto third_row = text.find('\n', text.find('\n', text.find('\n') + 1) + 1);
  write_metrics(text.substr(0, third_row) + ",7" + text.substr(third_row));  // one cell too many, line 3
  std::string e = error_of();
  EXPECT_NE(e.find(path + ":3"), std::string::npos) << e;

  write_metrics(metrics_text(kAllColumns, 5, [](const std::string& name, int r) {
    return name == "winrate" && r == 2 ? std::string("abc") : synthetic_cell(name, r);
  }));
  e = error_of();
  EXPECT_NE(e.find(path + ":4"), std::string::npos) << e;
  EXPECT_NE(e.find("winrate"), std::string::npos) << e;

  write_metrics("update,winrate\n1,0.5\n");  // no x axis
  e = error_of();
  EXPECT_NE(e.find(path), std::string::npos) << e;
  EXPECT_NE(e.find("env_steps"), std::string::npos) << e;

  write_metrics("");
  e = error_of();
  EXPECT_NE(e.find(path), std::string::npos) << e;
}

TEST_F(LearningCurvesTest, RowStillBeingAppendedIsIgnored) {
  std::string text = metrics_text(kAllColumns, 12, synthetic_cell);
  text += "12,0,13000,0";  // the trainer is writing the next row right now
  write_metrics(text);
  std::string msg;
  ASSERT_NO_THROW(write_learning_curves(dir_.string(), &msg));
  EXPECT_EQ(CsvTable::read((dir_ / "curves_data.csv").string()).rows(), 12u);
}

TEST_F(LearningCurvesTest, WritesPngWhenGnuplotIsAvailable) {
  if (!gnuplot_available()) GTEST_SKIP() << "gnuplot not on the PATH (apt-get install gnuplot-nox)";
  write_metrics(metrics_text(kAllColumns, 60, [](const std::string& name, int r) {
    if (name == "ll_return" || name == "hl_return") return std::to_string(std::sin(r * 0.3) + r * 0.05);
    if (name == "greedy_entropy" || name == "off_center_share" || name.rfind("middle_share", 0) == 0)
      return std::string("0.4");
    return synthetic_cell(name, r);
  }));
  std::string msg;
  ASSERT_TRUE(write_learning_curves(dir_.string(), &msg)) << msg;
  const fs::path png = dir_ / "curves.png";
  EXPECT_EQ(msg, png.string());
  ASSERT_TRUE(fs::exists(png));
  EXPECT_GT(fs::file_size(png), 1000u);
  EXPECT_EQ(slurp(png).substr(1, 3), "PNG");
  // Only the final image: the temporary one was renamed.
  for (const auto& e : fs::directory_iterator(dir_))
    EXPECT_EQ(e.path().filename().string().find(".tmp"), std::string::npos) << e.path();

  // The kept script redraws the figure by hand.
  fs::remove(png);
  const std::string cmd = "cd '" + dir_.string() + "' && gnuplot curves.gp >/dev/null 2>&1";
  ASSERT_EQ(std::system(cmd.c_str()), 0);
  EXPECT_GT(fs::file_size(png), 1000u);
}

TEST_F(LearningCurvesTest, HeaderOnlyMetricsGiveEmptyPanels) {
  write_metrics(metrics_text(kAllColumns, 0, synthetic_cell));
  std::string msg;
  const bool ok = write_learning_curves(dir_.string(), &msg);
  EXPECT_TRUE(fs::exists(dir_ / "curves.gp"));
  EXPECT_EQ(CsvTable::read((dir_ / "curves_data.csv").string()).rows(), 0u);
  if (gnuplot_available()) {
    EXPECT_TRUE(ok) << msg;
    EXPECT_TRUE(fs::exists(dir_ / "curves.png"));
  }
}

TEST_F(LearningCurvesTest, MissingGnuplotIsAMessageNotAnError) {
  write_metrics(metrics_text(kAllColumns, 5, synthetic_cell));
  const char* old = std::getenv("PATH");
  const std::string saved = old ? old : "";
  ::setenv("PATH", dir_.c_str(), 1);  // no gnuplot here
  std::string msg;
  bool ok = true;
  EXPECT_NO_THROW(ok = write_learning_curves(dir_.string(), &msg));
  ::setenv("PATH", saved.c_str(), 1);
  EXPECT_FALSE(ok);
  EXPECT_NE(msg.find("gnuplot"), std::string::npos) << msg;
  EXPECT_TRUE(fs::exists(dir_ / "curves.gp"));
  EXPECT_TRUE(fs::exists(dir_ / "curves_data.csv"));
  EXPECT_FALSE(fs::exists(dir_ / "curves.png"));
}

TEST_F(LearningCurvesTest, FailedGnuplotKeepsThePreviousImage) {
  write_metrics(metrics_text(kAllColumns, 5, synthetic_cell));
  { std::ofstream(dir_ / "curves.png", std::ios::binary) << "previous image"; }
  // A gnuplot that writes half an image to the name it is given, then fails.
  const fs::path bin = dir_ / "bin";
  fs::create_directories(bin);
  {
    std::ofstream fake(bin / "gnuplot");
    fake << "#!/bin/sh\n"
            "[ \"$1\" = -e ] || exit 2\n"
            "out=\"${2#f16race_output=}\"; out=\"${out#\\'}\"; out=\"${out%\\'}\"\n"
            "echo half > \"$out\"\n"
            "exit 1\n";
  }
  fs::permissions(bin / "gnuplot", fs::perms::owner_all);
  const char* old = std::getenv("PATH");
  const std::string saved = old ? old : "";
  ::setenv("PATH", bin.c_str(), 1);
  std::string msg;
  bool ok = true;
  EXPECT_NO_THROW(ok = write_learning_curves(dir_.string(), &msg));
  ::setenv("PATH", saved.c_str(), 1);
  EXPECT_FALSE(ok);
  EXPECT_NE(msg.find("gnuplot failed"), std::string::npos) << msg;
  EXPECT_EQ(slurp(dir_ / "curves.png"), "previous image");
  for (const auto& e : fs::directory_iterator(dir_))
    EXPECT_EQ(e.path().filename().string().find(".tmp"), std::string::npos) << e.path();
}

}  // namespace

// A draw beside training: the same files as a draw in line, busy until it is done, its problem
// (a malformed metrics.csv naming the file) returned by wait(), which then says no more.
TEST_F(LearningCurvesTest, BackgroundDrawWritesTheFiguresAndReportsItsProblem) {
  write_metrics(metrics_text(kAllColumns, 30, synthetic_cell));
  {
    f16race::io::BackgroundCurves curves;
    curves.start(dir_.string());
    const std::string problem = curves.wait();
    EXPECT_FALSE(curves.busy());
    EXPECT_EQ(CsvTable::read((dir_ / "curves_data.csv").string()).rows(), 30u);
    if (gnuplot_available()) {
      EXPECT_EQ(problem, "");
      EXPECT_GT(fs::file_size(dir_ / "curves.png"), 1000u);
    } else {
      EXPECT_NE(problem.find("gnuplot"), std::string::npos) << problem;
    }
    write_metrics("update,winrate\n1,0.5\n");  // no env_steps column
    curves.start(dir_.string());
    const std::string bad = curves.wait();
    EXPECT_NE(bad.find((dir_ / "metrics.csv").string()), std::string::npos) << bad;
    EXPECT_EQ(curves.wait(), "");  // reported once
    write_metrics("update,winrate\n1,0.5\n");
    curves.start(dir_.string());
    while (curves.busy()) std::this_thread::sleep_for(std::chrono::milliseconds(1));  // it has read the file
    write_metrics(metrics_text(kAllColumns, 7, synthetic_cell));
    curves.start(dir_.string());  // the failed draw's problem is not lost by the next start
    EXPECT_NE(curves.wait().find("env_steps"), std::string::npos);
    fs::remove(dir_ / "curves_data.csv");
    write_metrics(metrics_text(kAllColumns, 7, synthetic_cell));
    curves.start(dir_.string());
  }  // the destructor waits for the draw under way
  EXPECT_EQ(CsvTable::read((dir_ / "curves_data.csv").string()).rows(), 7u);
}
