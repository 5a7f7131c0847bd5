#include "io/learning_curves.hpp"

#include <algorithm>
#include <cerrno>
#include <cmath>
#include <cstdlib>
#include <cstring>
#include <filesystem>
#include <fstream>
#include <limits>
#include <sstream>
#include <string>
#include <system_error>
#include <vector>

#include <sys/resource.h>

#include "io/csv_table.hpp"
#include "io/plot.hpp"

namespace f16race::io {

namespace {

namespace fs = std::filesystem;

constexpr double kNaN = std::numeric_limits<double>::quiet_NaN();

// One plotted metric: a metrics.csv column.
struct Metric {
  const char* column;
  const char* label;  // legend entry
  const char* color;  // '#rrggbb'
  bool hl_only;       // only rows with phase_hl == 1
  bool y2;            // right axis
};

// Left axis: autoscaled, 0..1 (rates, comparable between runs), or from 0 up to the data (shares
// that stay small).
enum class YRange { kAuto, kUnit, kFromZero };

struct PanelDef {
  const char* title;
  const char* ylabel;
  const char* y2label;  // non-empty: the panel has a right axis, 0..1
  YRange range;
  std::vector<Metric> metrics;
};

const std::vector<PanelDef>& panel_defs() {
  static const std::vector<PanelDef> defs = {
      {"Finish rate and winrate (vs pool/self)", "share of races", "", YRange::kUnit,
       {{"finish_rate", "finish rate", "#2ca02c", false, false},
        {"winrate", "winrate", "#1f77b4", false, false}}},
      {"LL return", "per learner aircraft and race", "", YRange::kAuto, {{"ll_return", "ll_return", "#1f77b4", false, false}}},
      {"HL return", "summed r_HL per learner aircraft and race", "", YRange::kAuto, {{"hl_return", "hl_return", "#9467bd", false, false}}},
      {"HL diagnostics", "q_spread", "share / normalised entropy", YRange::kAuto,
       {{"q_spread", "q_spread (L)", "#d62728", false, false},
        {"greedy_entropy", "greedy_entropy (R)", "#ff7f0e", false, true},
        {"off_center_share", "off_center_share (R)", "#17becf", false, true},
        {"middle_share_x", "middle_share_x (R)", "#7f7f7f", false, true},
        {"middle_share_y", "middle_share_y (R)", "#bcbd22", false, true},
        {"middle_share_z", "middle_share_z (R)", "#9467bd", false, true}}},
      {"ES target shares (HL-phase rows)", "share of targets", "", YRange::kFromZero,
       {{"es_end_atom_share", "es_end_atom_share", "#8c564b", true, false},
        {"es_huber_share", "es_huber_share", "#e377c2", true, false}}},
      {"Distance to the HL goal", "goal distance [ft]", "", YRange::kAuto,
       {{"goal_dist_ft", "goal_dist_ft", "#2ca02c", false, false}}},
  };
  return defs;
}

std::string trim(const std::string& s) {
  std::size_t b = 0, e = s.size();
  while (b < e && (s[b] == ' ' || s[b] == '\t' || s[b] == '\r')) ++b;
  while (e > b && (s[e - 1] == ' ' || s[e - 1] == '\t' || s[e - 1] == '\r')) --e;
  return s.substr(b, e - b);
}

std::string read_text(const std::string& path) {
  std::error_code ec;
  if (fs::is_directory(path, ec)) throw CsvError(path + ": is a directory, not the run's metrics CSV");
  std::ifstream in(path, std::ios::binary);
  if (!in) {
    const int err = errno;
    throw CsvError(path + ": cannot open file (" + std::strerror(err) +
                   "); pass a run folder that holds the metrics.csv written by `f16race train`");
  }
  std::ostringstream ss;
  ss << in.rdbuf();
  if (in.bad()) throw CsvError(path + ": read error; check the file is a readable regular file");
  return ss.str();
}

// The trainer appends one line per update; a last line without its newline and with fewer cells
// than the header is the row being written right now, not a malformed file.
void drop_partial_last_line(std::string* text) {
  if (text->empty() || text->back() == '\n') return;
  const auto last_nl = text->find_last_of('\n');
  if (last_nl == std::string::npos) return;  // the header alone
  const auto header_end = text->find('\n');
  const auto cells = [](const std::string& line) { return std::count(line.begin(), line.end(), ',') + 1; };
  if (cells(text->substr(last_nl + 1)) < cells(text->substr(0, header_end))) text->erase(last_nl + 1);
}

// Empty, nan and inf cells are NaN (skipped points); other non-numbers make the file malformed.
std::vector<double> column_values(const CsvTable& t, const std::string& name) {
  const std::size_t c = t.column_index(name);
  std::vector<double> out(t.rows(), kNaN);
  for (std::size_t r = 0; r < t.rows(); ++r) {
    const std::string text = trim(t.cell(r, c));
    if (text.empty()) continue;
    char* end = nullptr;
    const double v = std::strtod(text.c_str(), &end);
    if (end != text.c_str() + text.size()) {
      // parse() keeps every line after the header as a row, so row r is on line r + 2.
      throw CsvError(t.source() + ":" + std::to_string(r + 2) + ": column '" + name + "' has non-numeric value '" +
                     t.cell(r, c) + "'; expected a number, nan or an empty cell");
    }
    if (std::isfinite(v)) out[r] = v;
  }
  return out;
}

// Mean of the last `window` finite values up to each row; NaN where the row's own value is NaN.
std::vector<double> running_mean(const std::vector<double>& v, int window) {
  std::vector<double> out(v.size(), kNaN);
  std::vector<double> recent;  // the valid values so far, newest last
  for (std::size_t r = 0; r < v.size(); ++r) {
    if (std::isnan(v[r])) continue;
    recent.push_back(v[r]);
    const std::size_t n = std::min<std::size_t>(recent.size(), static_cast<std::size_t>(window));
    double sum = 0.0;
    for (std::size_t k = recent.size() - n; k < recent.size(); ++k) sum += recent[k];
    out[r] = sum / static_cast<double>(n);
  }
  return out;
}

std::string run_name(const std::string& run_dir) {
  std::error_code ec;
  fs::path p = fs::absolute(run_dir, ec);
  if (ec) p = run_dir;
  p = p.lexically_normal();
  if (p.filename().empty()) p = p.parent_path();  // "runs/a/" and "." end in an empty name
  const std::string name = p.filename().string();
  return name.empty() ? run_dir : name;
}

std::string rgba(const char* color, const char* alpha) { return std::string("#") + alpha + (color + 1); }

// The data file's columns: env_steps_M first, then each plotted metric's raw and smoothed values.
struct CurveData {
  std::vector<std::string> header = {"env_steps_M"};
  std::vector<std::vector<double>> columns = std::vector<std::vector<double>>(1);
};

// Rows of metrics.csv with a finite env_steps, and what the panels need of them.
struct CurveRows {
  std::vector<std::size_t> rows;
  std::vector<double> phase_hl;  // per table row; 1 everywhere without the column (every row is HL)
  double x_min = std::numeric_limits<double>::infinity(), x_max = -std::numeric_limits<double>::infinity();
};

CurveRows curve_rows(const CsvTable& table, CurveData* data) {
  CurveRows c;
  const std::vector<double> steps = column_values(table, "env_steps");
  for (std::size_t r = 0; r < steps.size(); ++r)
    if (!std::isnan(steps[r])) c.rows.push_back(r);
  c.phase_hl = table.has_column("phase_hl") ? column_values(table, "phase_hl") : std::vector<double>(table.rows(), 1.0);
  for (std::size_t r : c.rows) {  // the x axis in millions
    data->columns[0].push_back(steps[r] / 1e6);
    c.x_min = std::min(c.x_min, steps[r] / 1e6);
    c.x_max = std::max(c.x_max, steps[r] / 1e6);
  }
  return c;
}

// A panel's metrics that have data: appended to `data` (raw, then smoothed); with the 1-based
// gnuplot column of each one's raw values.
struct PresentMetrics {
  std::vector<const Metric*> metrics;
  std::vector<std::size_t> raw_col;
};

PresentMetrics add_panel_columns(const PanelDef& def, const CsvTable& table, const CurveRows& c, CurveData* data) {
  PresentMetrics p;
  for (const Metric& m : def.metrics) {
    if (!table.has_column(m.column)) continue;
    const std::vector<double> all = column_values(table, m.column);
    std::vector<double> raw;
    bool any = false;
    for (std::size_t r : c.rows) {
      const bool eligible = !m.hl_only || c.phase_hl[r] == 1.0;
      raw.push_back(eligible ? all[r] : kNaN);
      any = any || !std::isnan(raw.back());
    }
    if (!any) continue;
    data->header.push_back(m.column);
    data->header.push_back(std::string(m.column) + "_smooth");
    data->columns.push_back(raw);
    data->columns.push_back(running_mean(raw, kLearningCurveWindow));
    p.metrics.push_back(&m);
    p.raw_col.push_back(data->columns.size() - 1);  // raw is 0-based columns.size() - 2
  }
  return p;
}

// Every panel sets all it uses (settings carry over between the panels of a multiplot), with the
// same margins everywhere so the x axes of a column line up.
constexpr const char* kPanelReset =
    "set datafile missing NaN\nset offsets 0,0,0,0\nunset y2tics\nunset y2label\nset ytics mirror autofreq\n"
    "set lmargin 10\nset rmargin 11\nset format x '% h'\nset format y '% h'\n";

PlotPanel empty_panel(const PanelDef& def, PlotPanel panel) {
  std::string names;
  for (const Metric& m : def.metrics) names += (names.empty() ? "" : ", ") + std::string(m.column);
  panel.extra = std::string(kPanelReset) + "unset key\nset format x ''\nset format y ''\n"
                "set label 1 'no data yet' at graph 0.5,0.55 center\n"
                "set label 2 '(" + names + ")' at graph 0.5,0.45 center";
  return panel;  // no series: render_plot draws an empty frame
}

PlotPanel curve_panel(const PanelDef& def, const PresentMetrics& p, const CurveRows& c, const std::string& data_file) {
  PlotPanel panel;
  panel.title = def.title;
  panel.xlabel = "env steps [millions]";
  panel.ylabel = def.ylabel;
  if (p.metrics.empty()) return empty_panel(def, panel);
  bool any_y1 = false;
  for (const Metric* m : p.metrics) any_y1 = any_y1 || !m->y2;
  // Without a left-axis metric the right-axis ones move to the left axis (gnuplot needs one).
  const bool use_y2 = any_y1 && def.y2label[0] != '\0' &&
                      std::any_of(p.metrics.begin(), p.metrics.end(), [](const Metric* m) { return m->y2; });
  std::string extra = kPanelReset;
  if (c.x_min < c.x_max) extra += "set xrange [" + format_double(c.x_min) + ":" + format_double(c.x_max) + "]\n";
  const bool key = p.metrics.size() > 1;
  // Fixed 0..1 ranges get headroom above 1 for the legend; autoscaled ones an offset.
  const bool two_rows = p.metrics.size() > 2;  // the legend wraps
  const std::string unit = !key ? "[-0.02:1.02]" : two_rows ? "[-0.02:1.4]" : "[-0.02:1.22]";
  const bool moved = !any_y1;
  if (def.range == YRange::kUnit || moved) {
    extra += "set yrange " + unit + "\nset ytics 0,0.2,1\n";
  } else {
    if (def.range == YRange::kFromZero) extra += "set yrange [0:*]\n";
    if (key) extra += two_rows ? "set offsets 0,0,graph 0.35,0\n" : "set offsets 0,0,graph 0.18,0\n";
  }
  if (moved) panel.ylabel = def.y2label;
  if (use_y2)
    extra += "set ytics nomirror\nset y2tics 0,0.2,1\nset y2range " + unit + "\nset y2label '" +
             std::string(def.y2label) + "'\n";
  panel.extra = extra + (key ? "set key inside top left horizontal opaque samplen 2" : "unset key");
  for (std::size_t k = 0; k < p.metrics.size(); ++k) {
    const Metric& m = *p.metrics[k];
    const std::string axes = use_y2 && m.y2 ? " axes x1y2" : "";
    const std::string raw = "1:" + std::to_string(p.raw_col[k]), smooth = "1:" + std::to_string(p.raw_col[k] + 1);
    panel.series.push_back({data_file, raw, "points pt 7 ps 0.35 lc rgb '" + rgba(m.color, "B0") + "'" + axes, "", ""});
    panel.series.push_back({data_file, smooth, std::string("lines lw 2 lc rgb '") + m.color + "'" + axes,
                            !key ? "" : use_y2 ? m.label : m.column, ""});  // (L)/(R) only with two axes
  }
  return panel;
}

}  // namespace

bool write_learning_curves(const std::string& run_dir, std::string* message) {
  const fs::path dir(run_dir.empty() ? "." : run_dir);
  const std::string metrics_path = (dir / "metrics.csv").string();
  std::string text = read_text(metrics_path);
  drop_partial_last_line(&text);
  const CsvTable table = CsvTable::parse(text, metrics_path);

  CurveData data;
  const CurveRows rows = curve_rows(table, &data);
  PlotSpec spec;
  spec.output = (dir / "curves.png").string();
  spec.width_px = 1600;
  spec.height_px = 1000;
  spec.rows = 2;
  spec.cols = 3;
  spec.title = run_name(run_dir);
  spec.atomic_output = true;
  const std::string data_file = "curves_data.csv";
  for (const PanelDef& def : panel_defs())
    spec.panels.push_back(curve_panel(def, add_panel_columns(def, table, rows, &data), rows, data_file));

  write_csv((dir / data_file).string(), data.header, data.columns);
  return render_plot(spec, (dir / "curves.gp").string(), message);
}

BackgroundCurves::~BackgroundCurves() { wait(); }

void BackgroundCurves::start(const std::string& run_dir) {
  // The previous draw ends first; a problem of it not yet read stays for wait() (the new draw only
  // ever writes one of its own).
  if (worker_.joinable()) worker_.join();
  busy_ = true;
  worker_ = std::thread([this, run_dir] {
    // Linux: the calling thread's niceness, which the gnuplot it starts inherits.
    (void)setpriority(PRIO_PROCESS, 0, 10);
    std::string message;
    try {
      if (!write_learning_curves(run_dir, &message)) problem_ = message;
    } catch (const std::exception& e) {
      problem_ = e.what();
    }
    busy_ = false;
  });
}

std::string BackgroundCurves::wait() {
  if (worker_.joinable()) worker_.join();
  std::string problem;
  problem.swap(problem_);
  return problem;
}

}  // namespace f16race::io
