#include "io/csv_table.hpp"

#include <gtest/gtest.h>

#include <cfloat>
#include <cmath>
#include <cstdint>
#include <cstring>
#include <filesystem>
#include <fstream>
#include <limits>
#include <sstream>
#include <string>
#include <vector>

#include <unistd.h>

namespace fs = std::filesystem;
using f16race::io::CsvError;
using f16race::io::CsvTable;
using f16race::io::format_double;
using f16race::io::write_csv;

namespace {

std::uint64_t bits(double v) {
  std::uint64_t b;
  std::memcpy(&b, &v, sizeof b);
  return b;
}

bool contains(const std::string& hay, const std::string& needle) {
  return hay.find(needle) != std::string::npos;
}

// Runs f, expects CsvError, returns its message.
template <class F>
std::string error_of(F f) {
  try {
    f();
  } catch (const CsvError& e) {
    return e.what();
  }
  ADD_FAILURE() << "expected CsvError";
  return "";
}

// Fresh per-test folder so tests never see each other's files.
class CsvTableTest : public ::testing::Test {
 protected:
  void SetUp() override {
    const auto* info = ::testing::UnitTest::GetInstance()->current_test_info();
    dir_ = fs::temp_directory_path() /
           ("f16race_csv_" + std::to_string(::getpid()) + "_" + info->name());
    fs::remove_all(dir_);
    fs::create_directories(dir_);
  }
  void TearDown() override { fs::remove_all(dir_); }

  static std::string slurp(const fs::path& p) {
    std::ifstream in(p, std::ios::binary);
    std::ostringstream ss;
    ss << in.rdbuf();
    return ss.str();
  }

  static void spit(const fs::path& p, const std::string& text) {
    std::ofstream out(p, std::ios::binary);
    out << text;
  }

  fs::path dir_;
};

TEST_F(CsvTableTest, AwkwardDoublesRoundTripBitIdentical) {
  const std::vector<double> vals = {0.1,     1.0 / 3.0, 1e-300, -0.0, 0.06000000000000001,
                                    DBL_MAX, -DBL_MAX,  DBL_MIN, 4.9e-324, 123456789.0};
  std::vector<double> neg;
  for (double v : vals) neg.push_back(-v);
  const fs::path p = dir_ / "rt.csv";
  write_csv(p.string(), {"x", "negx"}, {vals, neg});

  const CsvTable t = CsvTable::read(p.string());
  ASSERT_EQ(t.rows(), vals.size());
  const std::vector<double> x = t.numeric("x");
  const std::vector<double> nx = t.numeric("negx");
  for (std::size_t i = 0; i < vals.size(); ++i) {
    EXPECT_EQ(bits(x[i]), bits(vals[i])) << "row " << i << " text '" << t.cell(i, 0) << "'";
    EXPECT_EQ(bits(nx[i]), bits(neg[i])) << "row " << i;
  }
  // -0.0 must keep its sign bit, not collapse to +0.
  EXPECT_TRUE(std::signbit(x[3]));
  EXPECT_FALSE(std::signbit(nx[3]));
}

TEST(FormatDouble, ShortestForms) {
  EXPECT_EQ(format_double(0.1), "0.1");
  EXPECT_EQ(format_double(1e-300), "1e-300");
  EXPECT_EQ(format_double(0.06000000000000001), "0.06000000000000001");
  EXPECT_EQ(format_double(-0.0), "-0");
  EXPECT_EQ(format_double(2.0), "2");
  EXPECT_EQ(format_double(std::numeric_limits<double>::quiet_NaN()), "nan");
  EXPECT_EQ(format_double(std::numeric_limits<double>::infinity()), "inf");
  EXPECT_EQ(format_double(-std::numeric_limits<double>::infinity()), "-inf");
}

TEST_F(CsvTableTest, NanAndInfRoundTrip) {
  const double inf = std::numeric_limits<double>::infinity();
  const fs::path p = dir_ / "nan.csv";
  write_csv(p.string(), {"v"}, {{std::numeric_limits<double>::quiet_NaN(), inf, -inf, 1e-5}});
  EXPECT_EQ(slurp(p), "v\nnan\ninf\n-inf\n1e-05\n");
  const std::vector<double> v = CsvTable::read(p.string()).numeric("v");
  ASSERT_EQ(v.size(), 4u);
  EXPECT_TRUE(std::isnan(v[0]));
  EXPECT_EQ(v[1], inf);
  EXPECT_EQ(v[2], -inf);
  EXPECT_EQ(v[3], 1e-5);
}

TEST_F(CsvTableTest, StringColumnsAppendedAfterNumeric) {
  const fs::path p = dir_ / "s.csv";
  write_csv(p.string(), {"t", "alt"}, {{0.0, 0.5}, {1000.0, 1000.25}}, {"mode"},
            {{"cruise", "climb"}});
  EXPECT_EQ(slurp(p), "t,alt,mode\n0,1000,cruise\n0.5,1000.25,climb\n");
  const CsvTable t = CsvTable::read(p.string());
  EXPECT_EQ(t.header(), (std::vector<std::string>{"t", "alt", "mode"}));
  EXPECT_EQ(t.cell(1, t.column_index("mode")), "climb");
  EXPECT_EQ(t.numeric("alt")[1], 1000.25);
}

TEST_F(CsvTableTest, MissingFileErrorNamesPath) {
  const std::string path = (dir_ / "does_not_exist.csv").string();
  const std::string msg = error_of([&] { CsvTable::read(path); });
  EXPECT_TRUE(contains(msg, path)) << msg;
  EXPECT_EQ(msg.find('\n'), std::string::npos) << "message must be one line: " << msg;
}

TEST(CsvParse, RaggedRowReportsLineNumber) {
  const std::string text = "a,b,c\n1,2,3\n4,5,6\n7,8\n9,10,11\n";
  const std::string msg = error_of([&] { CsvTable::parse(text, "ragged.csv"); });
  EXPECT_TRUE(contains(msg, "ragged.csv:4")) << msg;
  EXPECT_TRUE(contains(msg, "2 cells")) << msg;
  EXPECT_FALSE(contains(msg, "ragged.csv:3")) << msg;
}

TEST(CsvParse, UnknownColumnListsColumns) {
  const CsvTable t = CsvTable::parse("alpha,beta,gamma\n1,2,3\n", "cols.csv");
  EXPECT_FALSE(t.has_column("delta"));
  EXPECT_TRUE(t.has_column("beta"));
  EXPECT_EQ(t.column_index("gamma"), 2u);
  const std::string msg = error_of([&] { t.column_index("delta"); });
  EXPECT_EQ(msg, "cols.csv: no column 'delta' (columns: alpha, beta, gamma)");
  const std::string msg2 = error_of([&] { t.numeric("delta"); });
  EXPECT_TRUE(contains(msg2, "alpha, beta, gamma")) << msg2;
}

TEST(CsvParse, NonNumericCellNamesLineColumnAndText) {
  const CsvTable t = CsvTable::parse("t,alt\n0,100\n1,12x4\n2,300\n", "bad.csv");
  const std::string msg = error_of([&] { t.numeric("alt"); });
  EXPECT_TRUE(contains(msg, "bad.csv:3")) << msg;
  EXPECT_TRUE(contains(msg, "'alt'")) << msg;
  EXPECT_TRUE(contains(msg, "12x4")) << msg;
  // Column t is fine and must still convert.
  EXPECT_EQ(t.numeric("t"), (std::vector<double>{0.0, 1.0, 2.0}));
  // An empty cell is not a number either.
  const CsvTable e = CsvTable::parse("a,b\n1,\n", "empty_cell.csv");
  EXPECT_TRUE(contains(error_of([&] { e.numeric("b"); }), "empty_cell.csv:2"));
}

TEST(CsvParse, TrimsWhitespaceAndAcceptsStrtodForms) {
  const CsvTable t =
      CsvTable::parse(" a , b \n 1e-5 ,nan\n  +2.5\t, -inf \n0.06000000000000001,INF\n", "ws.csv");
  EXPECT_EQ(t.header(), (std::vector<std::string>{"a", "b"}));
  const std::vector<double> a = t.numeric("a");
  const std::vector<double> b = t.numeric("b");
  EXPECT_EQ(a, (std::vector<double>{1e-5, 2.5, 0.06000000000000001}));
  EXPECT_TRUE(std::isnan(b[0]));
  EXPECT_EQ(b[1], -std::numeric_limits<double>::infinity());
  EXPECT_EQ(b[2], std::numeric_limits<double>::infinity());
}

TEST(CsvParse, CrlfAndTrailingBlankLines) {
  const CsvTable t = CsvTable::parse("x,y\r\n1,2\r\n3,4\r\n\r\n\n", "crlf.csv");
  EXPECT_EQ(t.header(), (std::vector<std::string>{"x", "y"}));
  ASSERT_EQ(t.rows(), 2u);
  EXPECT_EQ(t.cell(1, 1), "4");  // no stray '\r'
  EXPECT_EQ(t.numeric("y"), (std::vector<double>{2.0, 4.0}));
  // No trailing newline at all is also fine.
  EXPECT_EQ(CsvTable::parse("x\n7", "nonl.csv").numeric("x"), (std::vector<double>{7.0}));
}

// Spreadsheets write a UTF-8 byte-order mark: it is not part of the first column's name.
TEST(CsvParse, Utf8ByteOrderMarkIsSkipped) {
  const CsvTable t = CsvTable::parse("\xEF\xBB\xBFt_s,y\r\n0,1\r\n", "bom.csv");
  EXPECT_EQ(t.header(), (std::vector<std::string>{"t_s", "y"}));
  EXPECT_EQ(t.numeric("t_s"), (std::vector<double>{0.0}));
  EXPECT_TRUE(contains(error_of([] { CsvTable::parse("\xEF\xBB\xBF", "bom_only.csv"); }), "bom_only.csv: file is empty"));
}

// Encodings and line ends the reader cannot take are refused in one line naming the file.
TEST(CsvParse, Utf16AndBareCarriageReturnsAreRefusedNamingTheFile) {
  const std::string u16 = error_of([] { CsvTable::parse(std::string("\xFF\xFEt\0_\0s\0\n\0", 10), "u16.csv"); });
  EXPECT_TRUE(contains(u16, "u16.csv: is UTF-16")) << u16;
  const std::string cr = error_of([] { CsvTable::parse("t_s,y\r0,1\r1,2\r", "mac.csv"); });
  EXPECT_TRUE(contains(cr, "mac.csv:1: a carriage return inside the line")) << cr;
  EXPECT_EQ(cr.find('\n'), std::string::npos);
  const std::string mid = error_of([] { CsvTable::parse("a,b\n1,2\r3\n", "mid.csv"); });
  EXPECT_TRUE(contains(mid, "mid.csv:2:")) << mid;
}

// finite(): what a computation starts from; nan, inf and overflowing cells name file, line, column.
TEST(CsvParse, FiniteRefusesNanInfAndOverflowNamingLineAndColumn) {
  const CsvTable t = CsvTable::parse("a,b,c,d\n1,nan,2,3\n4,5,-inf,1e999\n", "f.csv");
  EXPECT_EQ(t.finite("a"), (std::vector<double>{1.0, 4.0}));
  std::string e = error_of([&] { t.finite("b"); });
  EXPECT_TRUE(contains(e, "f.csv:2: column 'b' is 'nan'; give a finite number")) << e;
  e = error_of([&] { t.finite("c"); });
  EXPECT_TRUE(contains(e, "f.csv:3: column 'c' is '-inf'")) << e;
  e = error_of([&] { t.finite("d"); });
  EXPECT_TRUE(contains(e, "f.csv:3: column 'd' is '1e999'")) << e;
  EXPECT_TRUE(std::isnan(t.numeric("b")[0]));  // numeric() still reads them (metrics leave them)
  EXPECT_EQ(t.line_of_row(1), 3u);
}

TEST(CsvParse, StructuralErrors) {
  EXPECT_TRUE(contains(error_of([] { CsvTable::parse("", "e.csv"); }), "e.csv"));
  EXPECT_TRUE(contains(error_of([] { CsvTable::parse("\n\r\n", "e2.csv"); }), "empty"));
  EXPECT_TRUE(contains(error_of([] { CsvTable::parse("\na,b\n1,2\n", "nh.csv"); }), "nh.csv:1"));
  const std::string dup = error_of([] { CsvTable::parse("a,b,a\n1,2,3\n", "dup.csv"); });
  EXPECT_TRUE(contains(dup, "duplicate")) << dup;
  EXPECT_TRUE(contains(dup, "'a'")) << dup;
  // Header-only file is valid with zero rows.
  EXPECT_EQ(CsvTable::parse("a,b\n", "h.csv").rows(), 0u);
  EXPECT_EQ(CsvTable::parse("a,b\n", "h.csv").source(), "h.csv");
}

TEST_F(CsvTableTest, AtomicWriteReplacesAndLeavesNoTemp) {
  const fs::path sub = dir_ / "nested" / "deeper";
  const fs::path p = sub / "out.csv";
  write_csv(p.string(), {"a"}, {{1.0, 2.0, 3.0}});  // creates parent directories
  ASSERT_TRUE(fs::exists(p));
  write_csv(p.string(), {"b"}, {{9.5}});           // replaces the existing file
  EXPECT_EQ(slurp(p), "b\n9.5\n");
  std::size_t n = 0;
  for (const auto& entry : fs::directory_iterator(sub)) {
    ++n;
    EXPECT_EQ(entry.path().filename(), "out.csv") << "leftover: " << entry.path();
  }
  EXPECT_EQ(n, 1u);
}

TEST_F(CsvTableTest, WriteRejectsUnequalColumnsWithoutTouchingTarget) {
  const fs::path p = dir_ / "keep.csv";
  spit(p, "old\n1\n");
  const std::string msg =
      error_of([&] { write_csv(p.string(), {"a", "b"}, {{1.0, 2.0}, {3.0}}); });
  EXPECT_TRUE(contains(msg, p.string())) << msg;
  EXPECT_TRUE(contains(msg, "'b'")) << msg;
  EXPECT_EQ(slurp(p), "old\n1\n");
  // Header/column count mismatch and string columns of the wrong length are rejected too.
  EXPECT_FALSE(error_of([&] { write_csv(p.string(), {"a"}, {{1.0}, {2.0}}); }).empty());
  EXPECT_FALSE(error_of([&] {
                 write_csv(p.string(), {"a"}, {{1.0, 2.0}}, {"mode"}, {{"x"}});
               }).empty());
  EXPECT_EQ(slurp(p), "old\n1\n");
}

TEST_F(CsvTableTest, WriteFailureNamesPathAndErrno) {
  // A regular file where a parent directory should be makes creation fail.
  const fs::path blocker = dir_ / "blocker";
  spit(blocker, "x");
  const std::string target = (blocker / "out.csv").string();
  const std::string msg = error_of([&] { write_csv(target, {"a"}, {{1.0}}); });
  EXPECT_TRUE(contains(msg, target)) << msg;
  EXPECT_TRUE(contains(msg, "(")) << msg;
}

TEST(CsvRead, DevicesAndFoldersAreRefusedInOneLine) {
  try {
    CsvTable::read("/dev/zero");  // would be read forever
    FAIL() << "a device was read as a CSV file";
  } catch (const CsvError& e) {
    EXPECT_NE(std::string(e.what()).find("/dev/zero: is not a regular file"), std::string::npos) << e.what();
  }
  EXPECT_THROW(CsvTable::read("/"), CsvError);
}

TEST(CsvParse, LargeTableParses) {
  // ~1000 rows x 50 columns, the expected working size.
  std::string text;
  for (int c = 0; c < 50; ++c) text += (c ? ",c" : "c") + std::to_string(c);
  text += '\n';
  for (int r = 0; r < 1000; ++r) {
    for (int c = 0; c < 50; ++c) {
      if (c) text += ',';
      text += format_double(r * 0.1 + c);
    }
    text += '\n';
  }
  const CsvTable t = CsvTable::parse(text, "big.csv");
  ASSERT_EQ(t.rows(), 1000u);
  const std::vector<double> c49 = t.numeric("c49");
  EXPECT_EQ(c49[999], 999 * 0.1 + 49);
  EXPECT_EQ(c49[0], 49.0);
}

}  // namespace
