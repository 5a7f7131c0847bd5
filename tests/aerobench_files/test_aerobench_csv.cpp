// The AeroBench-format CSV conversions behind `f16race simulate` and the model tests: what a
// request holds after reading a file, what a bad file says, and that our outputs use the
// reference format's column names.
#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <functional>
#include <limits>
#include <set>
#include <sstream>
#include <string>

#include "aerobench_files/aerobench_csv.hpp"
#include "dynamics/trim.hpp"
#include "io/input_error.hpp"
#include "support/temp_paths.hpp"

namespace f16race::aerobench_files {
namespace {

using namespace f16race::dynamics;

io::CsvTable load(const std::string& name) {
  return io::CsvTable::read(std::string(F16RACE_TEST_DATA_DIR) + "/" + name);
}

// A reference-format table with the given t_s values, every state and reference column, and
// state s = s + row / 10 so rows are told apart (airspeed 500 + that, and alpha, beta and theta
// a hundredth of it: a start state inside the model's domain).
io::CsvTable tiny_reference(const std::vector<double>& t_s) {
  std::ostringstream text;
  text << "t_s";
  for (const char* n : kStateNames) text << "," << n;
  for (const char* n : kRefNames) text << "," << n;
  text << "\n";
  for (std::size_t r = 0; r < t_s.size(); ++r) {
    text << t_s[r];
    for (int s = 0; s < kNumStates; ++s) {
      const double v = s + 0.1 * static_cast<double>(r);
      text << "," << (s == kVt ? 500.0 + v : s == kAlpha || s == kBeta || s == kTheta ? 0.01 * v : v);
    }
    for (int k = 0; k < kNumRefs; ++k) text << "," << 0.5 * k;
    text << "\n";
  }
  return io::CsvTable::parse(text.str(), "tiny.csv");
}

std::string message_of(const std::function<void()>& f) {
  try {
    f();
  } catch (const io::InputError& e) {
    return e.what();
  }
  return "(no io::InputError)";
}

TEST(RequestFromReference, GcasFileGivesStartStateTimesAndModeSegments) {
  const io::CsvTable ref = load("f_gcas_morelli.csv");
  ReplaySettings settings;
  settings.interp = RefInterp::kLinear;
  settings.dt_s = 0.005;
  const ReplayRequest req = request_from_reference(ref, settings);
  ASSERT_EQ(req.output_times_s.size(), 451u);
  EXPECT_EQ(req.output_times_s, ref.numeric("t_s"));
  EXPECT_EQ(req.x0[kVt], 540.0);
  EXPECT_EQ(req.x0[kAlt], 1000.0);
  EXPECT_EQ(req.x0[kAlpha], ref.numeric("alpha_rad").front());
  EXPECT_EQ(req.refs.values[0], ref.numeric(kRefNames[0]));
  EXPECT_EQ(req.refs.interp, RefInterp::kLinear);
  EXPECT_EQ(req.dt_s, 0.005);
  // The autopilot goes standby -> roll -> pull: three segments, a new id exactly where `mode` changes.
  ASSERT_EQ(req.refs.segment.size(), 451u);
  const std::size_t mode = ref.column_index("mode");
  int changes = 0;
  for (std::size_t k = 1; k < ref.rows(); ++k) {
    const bool changed = ref.cell(k, mode) != ref.cell(k - 1, mode);
    changes += changed;
    EXPECT_EQ(req.refs.segment[k] - req.refs.segment[k - 1], changed ? 1 : 0) << "row " << k;
  }
  EXPECT_EQ(changes, 2);
  EXPECT_EQ(req.refs.segment.front(), 0);
  EXPECT_EQ(req.refs.segment.back(), 2);
}

TEST(RequestFromReference, WithoutModeColumnIsOneSegment) {
  const ReplayRequest req = request_from_reference(tiny_reference({0.0, 0.5, 1.0}), ReplaySettings{});
  EXPECT_TRUE(req.refs.segment.empty());
  EXPECT_DOUBLE_EQ(req.x0[kPsi], kPsi);  // first row: state s holds s
  EXPECT_EQ(req.refs.values[3], (std::vector<double>{1.5, 1.5, 1.5}));
}

TEST(RequestFromReference, BadFilesNameTheFileAndTheFix) {
  EXPECT_NE(message_of([] { request_from_reference(tiny_reference({0.0, 1.0, 1.0}), {}); })
                .find("tiny.csv: t_s must increase strictly (line 4)"),
            std::string::npos);
  EXPECT_NE(message_of([] { request_from_reference(tiny_reference({}), {}); }).find("tiny.csv: no data rows"),
            std::string::npos);
  const io::CsvTable no_alt = io::CsvTable::parse("t_s,vt_ftps\n0,540\n", "short.csv");
  EXPECT_NE(message_of([&] { request_from_reference(no_alt, {}); }).find("short.csv: missing column 'alpha_rad'"),
            std::string::npos);
}

// Start states and derivative points outside the model's domain (airspeed, the tables' alpha
// range, sideslip, pitch, altitude, engine power) and nan/inf cells are refused before anything
// is flown, naming the file, the line and the column.
TEST(StartStates, OutsideTheModelsDomainOrNonFiniteAreRefusedNamingFileLineAndColumn) {
  const std::string header = "vt_ftps,alpha_rad,beta_rad,phi_rad,theta_rad,psi_rad,p_radps,q_radps,r_radps,pn_ft,pe_ft,alt_ft,pow_pct\n";
  const std::string good = "540,0.037,0,0,0,0,0,0,0,0,0,1000,9\n";
  auto with = [&](int column, const std::string& value) {
    std::string row = good;
    std::size_t pos = 0;
    for (int k = 0; k < column; ++k) pos = row.find(',', pos) + 1;
    row.replace(pos, row.find_first_of(",\n", pos) - pos, value);
    return io::CsvTable::parse(header + good + row, "starts.csv");
  };
  EXPECT_EQ(initial_states(with(0, "600")).size(), 2u);
  const std::pair<int, const char*> bad[] = {
      {0, "starts.csv:3: start state vt_ftps = 0 is outside the model's domain [50, 3000]"},
      {1, "starts.csv:3: start state alpha_rad = 0.9 is outside the model's domain [-0.174533, 0.785398] rad (-10 to 45 deg)"},
      {2, "start state beta_rad = 0.9 is outside"},
      {4, "start state theta_rad = 1.6"},
      {11, "start state alt_ft = -20000"},
      {12, "start state pow_pct = 101"},
  };
  const char* values[] = {"0", "0.9", "0.9", "", "1.6", "", "", "", "", "", "", "-20000", "101"};
  for (const auto& [column, message] : bad) {
    const std::string e = message_of([&] { initial_states(with(column, values[column])); });
    EXPECT_NE(e.find(message), std::string::npos) << e;
  }
  EXPECT_NE(message_of([&] { initial_states(with(0, "nan")); }).find("starts.csv:3: column 'vt_ftps' is 'nan'"),
            std::string::npos);
  EXPECT_NE(message_of([&] { initial_states(with(9, "inf")); }).find("starts.csv:3: column 'pn_ft' is 'inf'"),
            std::string::npos);
  // A reference's start state is its first row.
  const io::CsvTable slow = io::CsvTable::parse(
      "t_s,vt_ftps,alpha_rad,beta_rad,phi_rad,theta_rad,psi_rad,p_radps,q_radps,r_radps,pn_ft,pe_ft,alt_ft,pow_pct,"
      "int_e_Nz_gs,int_e_ps_rad,int_e_Ny_r_mixed_s,Nz_ref_g,ps_ref_radps,Ny_r_ref_mixed,throttle_ref_delta\n"
      "0,10,0,0,0,0,0,0,0,0,0,0,1000,9,0,0,0,0,0,0,0\n",
      "ref.csv");
  EXPECT_NE(message_of([&] { request_from_reference(slow, {}); }).find("ref.csv:2: start state vt_ftps = 10 is outside"),
            std::string::npos);
  // A derivative point at airspeed 0 would divide by it.
  io::CsvTable points = load("deriv_plant_morelli.csv");
  std::ostringstream text;
  for (std::size_t c = 0; c < points.header().size(); ++c) text << (c ? "," : "") << points.header()[c];
  text << "\n";
  for (std::size_t c = 0; c < points.header().size(); ++c)
    text << (c ? "," : "") << (points.header()[c] == "vt_ftps" ? std::string("0") : points.cell(0, c));
  text << "\n";
  const io::CsvTable zero = io::CsvTable::parse(text.str(), "points.csv");
  EXPECT_NE(message_of([&] { evaluate_derivatives(zero, AeroModel::kMorelli); })
                .find("points.csv:2: state vt_ftps = 0 is outside the model's domain"),
            std::string::npos);
  // Commands: a nan reference would fly a nan aircraft.
  const io::CsvTable nan_cmd = io::CsvTable::parse("t_s,Nz_ref_g\n0,nan\n", "cmd.csv");
  EXPECT_NE(message_of([&] { request_from_commands(&nan_cmd, ScriptedRun{}, {}); }).find("cmd.csv:2: column 'Nz_ref_g' is 'nan'"),
            std::string::npos);
}

TEST(RequestFromCommands, NoFileFliesTheTrimForTheDuration) {
  ScriptedRun run;
  run.duration_s = 2.0;
  run.sample_s = 0.1;
  const ReplayRequest req = request_from_commands(nullptr, run, ReplaySettings{});
  TrimRequest tr;
  const TrimResult trim = trim_level_flight(tr);
  ASSERT_EQ(req.output_times_s.size(), 21u);
  EXPECT_DOUBLE_EQ(req.output_times_s.back(), 2.0);
  EXPECT_EQ(req.x0, trim.x0);
  ASSERT_EQ(req.refs.t_s, (std::vector<double>{0.0}));
  for (int r = 0; r < kNumRefs; ++r) EXPECT_EQ(req.refs.values[r], (std::vector<double>{trim.u_ref[r]})) << r;
}

TEST(RequestFromCommands, ColumnsAreOffsetsFromTrimAndMissingOnesHoldTrim) {
  const io::CsvTable cmd = io::CsvTable::parse("t_s,Nz_ref_g\n0,0\n1,2\n3,-1\n", "cmd.csv");
  ScriptedRun run;
  run.trim_vt_ftps = 600.0;
  run.trim_alt_ft = 8000.0;
  const ReplayRequest req = request_from_commands(&cmd, run, ReplaySettings{});
  TrimRequest tr;
  tr.vt_ftps = 600.0;
  tr.alt_ft = 8000.0;
  const TrimResult trim = trim_level_flight(tr);
  EXPECT_EQ(req.refs.t_s, (std::vector<double>{0.0, 1.0, 3.0}));
  EXPECT_EQ(req.refs.values[0], (std::vector<double>{trim.u_ref[0], trim.u_ref[0] + 2.0, trim.u_ref[0] - 1.0}));
  for (int r = 1; r < kNumRefs; ++r) EXPECT_EQ(req.refs.values[r], std::vector<double>(3, trim.u_ref[r])) << r;
}

TEST(RequestFromCommands, BadRequestsNameTheFileOrOption) {
  ScriptedRun run;
  const io::CsvTable header_only = io::CsvTable::parse("t_s,Nz_ref_g\n", "h.csv");
  EXPECT_NE(message_of([&] { request_from_commands(&header_only, run, {}); }).find("h.csv: has a header but no rows"),
            std::string::npos);
  const io::CsvTable no_refs = io::CsvTable::parse("t_s,foo\n0,1\n", "n.csv");
  EXPECT_NE(message_of([&] { request_from_commands(&no_refs, run, {}); }).find("n.csv: needs t_s and at least one of"),
            std::string::npos);
  const io::CsvTable backwards = io::CsvTable::parse("t_s,Nz_ref_g\n1,0\n0,0\n", "b.csv");
  EXPECT_NE(message_of([&] { request_from_commands(&backwards, run, {}); }).find("b.csv: t_s must increase strictly (line 3)"),
            std::string::npos);
  ScriptedRun huge;
  huge.duration_s = 1e9;
  EXPECT_NE(message_of([&] { request_from_commands(nullptr, huge, {}); }).find("more than 10 000 000 samples"),
            std::string::npos);
  ScriptedRun slow;
  slow.trim_vt_ftps = 50.0;  // far below the F-16's level-flight speed
  EXPECT_EQ(message_of([&] { request_from_commands(nullptr, slow, {}); }).rfind("--trim-vt/--trim-alt: trim at vt=50", 0),
            0u);
}

TEST(TrajectoryColumns, AreTheReferenceFormatsMinusMode) {
  const std::vector<std::string> ours = trajectory_header();
  std::vector<std::string> theirs = load("b_nz_pulse_stevens.csv").header();
  ASSERT_EQ(ours.size(), 45u);  // t_s, 16 states, 4 outputs, 4 refs, 4 surfaces, 16 derivatives
  theirs.erase(std::remove(theirs.begin(), theirs.end(), "mode"), theirs.end());
  EXPECT_EQ(std::set<std::string>(ours.begin(), ours.end()), std::set<std::string>(theirs.begin(), theirs.end()));
}

TEST(TrajectoryRows, HoldEachSampleInHeaderOrderAndRoundTripThroughTheFile) {
  ReplayResult result;
  ReplaySample s{};
  s.t_s = 0.25;
  for (int k = 0; k < kNumStates; ++k) {
    s.x[k] = 100.0 + k;
    s.xdot[k] = -1.0 - k;
  }
  for (int k = 0; k < kNumRefs; ++k) s.u_ref[k] = 10.0 + k;
  s.nz_g = 1.5;
  s.rudder_deg = -3.25;
  result.samples = {s, s};
  result.samples[1].t_s = 0.5;
  const std::vector<std::string> header = trajectory_header();
  const std::vector<std::vector<double>> rows = trajectory_rows(result);
  ASSERT_EQ(rows.size(), 2u);
  ASSERT_EQ(rows[0].size(), header.size());
  auto at = [&](std::size_t r, const std::string& name) {
    const auto c = std::find(header.begin(), header.end(), name);
    EXPECT_NE(c, header.end()) << name;
    return c == header.end() ? std::nan("") : rows[r][static_cast<std::size_t>(c - header.begin())];
  };
  EXPECT_EQ(at(1, "t_s"), 0.5);
  EXPECT_EQ(at(0, kStateNames[kAlt]), 100.0 + kAlt);
  EXPECT_EQ(at(0, kStateDerivativeNames[kVt]), -1.0);
  EXPECT_EQ(at(0, kRefNames[3]), 13.0);
  EXPECT_EQ(at(0, "Nz_g"), 1.5);
  EXPECT_EQ(at(0, kSurfaceNames[3]), -3.25);

  const std::string path = test_support::fresh_temp_path("aerobench_rows.csv");
  write_rows(path, header, rows);
  const io::CsvTable back = io::CsvTable::read(path);
  EXPECT_EQ(back.header(), header);
  for (const ColumnDiff& d : compare_columns(back, header, rows, 0, false)) EXPECT_EQ(d.worst, 0.0) << d.column;
}

TEST(CompareColumns, LargestDifferencePerSharedColumnWithItsRow) {
  const io::CsvTable theirs = io::CsvTable::parse("t_s,a,b\n0,1,-2\n1,3,4\n", "theirs.csv");
  const std::vector<std::string> header{"t_s", "a", "b", "only_ours"};
  const std::vector<std::vector<double>> rows{{0, 1, -2.5, 7}, {1, 3.5, 4, 7}};
  const std::vector<ColumnDiff> abs = compare_columns(theirs, header, rows, 1, false);
  ASSERT_EQ(abs.size(), 2u);  // t_s skipped by first_column, only_ours absent from theirs
  EXPECT_EQ(abs[0].column, "a");
  EXPECT_DOUBLE_EQ(abs[0].worst, 0.5);
  EXPECT_EQ(abs[0].at_row, 1u);
  EXPECT_EQ(abs[1].column, "b");
  EXPECT_DOUBLE_EQ(abs[1].worst, 0.5);
  EXPECT_EQ(abs[1].at_row, 0u);
  const std::vector<ColumnDiff> rel = compare_columns(theirs, header, rows, 1, true);
  EXPECT_DOUBLE_EQ(rel[0].worst, 0.5 / 3.0);
  EXPECT_DOUBLE_EQ(rel[1].worst, 0.5 / 2.0);
  std::vector<std::vector<double>> nan_rows = rows;
  nan_rows[1][2] = std::numeric_limits<double>::quiet_NaN();
  const ColumnDiff b = compare_columns(theirs, header, nan_rows, 1, false)[1];
  EXPECT_TRUE(std::isnan(b.worst));
  EXPECT_EQ(b.at_row, 1u);
}

// The conversion keeps the file's inputs and appends every probed value, so comparing from
// column n_inputs on checks the model at every value the file gives (the counts are those of
// tests/dynamics/test_derivatives.cpp).
TEST(EvaluateDerivatives, ClosedLoopAndPlantFilesMatchAeroBenchThroughTheConversion) {
  struct Case {
    const char* file;
    bool closed_loop;
    std::size_t n_inputs, n_compared;
  };
  for (const Case c : {Case{"deriv_closed_loop_stevens.csv", true, 20, 4 + 16 + 3},
                       Case{"deriv_plant_morelli.csv", false, 17, 38}}) {
    const io::CsvTable in = load(c.file);
    const DerivativeTable d =
        evaluate_derivatives(in, std::string(c.file).find("stevens") != std::string::npos ? AeroModel::kStevens
                                                                                           : AeroModel::kMorelli);
    EXPECT_EQ(d.closed_loop, c.closed_loop) << c.file;
    EXPECT_EQ(d.n_inputs, c.n_inputs) << c.file;
    ASSERT_EQ(d.rows.size(), in.rows()) << c.file;
    EXPECT_EQ(d.cases.size(), in.rows()) << c.file;
    EXPECT_EQ(d.cases.front(), in.cell(0, in.column_index("case"))) << c.file;
    for (std::size_t k = 0; k < d.n_inputs; ++k) EXPECT_EQ(d.rows[3][k], in.numeric(d.header[k])[3]) << c.file;
    const std::vector<ColumnDiff> diffs = compare_columns(in, d.header, d.rows, d.n_inputs, true);
    EXPECT_EQ(diffs.size(), c.n_compared) << c.file;
    for (const ColumnDiff& diff : diffs) EXPECT_LE(diff.worst, 1e-9) << c.file << " " << diff.column;
  }
}

}  // namespace
}  // namespace f16race::aerobench_files
