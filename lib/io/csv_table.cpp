#include "io/csv_table.hpp"

#include "io/atomic_file.hpp"

#include <cerrno>
#include <charconv>
#include <cmath>
#include <cstdlib>
#include <cstring>
#include <filesystem>
#include <fstream>
#include <sstream>
#include <system_error>


namespace f16race::io {

namespace {

std::string trim(const std::string& s) {
  std::size_t b = 0;
  std::size_t e = s.size();
  while (b < e && (s[b] == ' ' || s[b] == '\t' || s[b] == '\r')) ++b;
  while (e > b && (s[e - 1] == ' ' || s[e - 1] == '\t' || s[e - 1] == '\r')) --e;
  return s.substr(b, e - b);
}

// Splits one line on commas; an empty line yields one empty cell, matching
// how a one-column file with an empty value would look.
std::vector<std::string> split_line(const std::string& line) {
  std::vector<std::string> out;
  std::size_t start = 0;
  for (;;) {
    std::size_t pos = line.find(',', start);
    if (pos == std::string::npos) {
      out.push_back(line.substr(start));
      break;
    }
    out.push_back(line.substr(start, pos - start));
    start = pos + 1;
  }
  return out;
}

std::string join(const std::vector<std::string>& v) {
  std::string s;
  for (std::size_t i = 0; i < v.size(); ++i) {
    if (i) s += ", ";
    s += v[i];
  }
  return s;
}

std::string errno_text(int err) { return std::strerror(err); }

void check_cell_text(const std::string& path, const std::string& what, const std::string& text) {
  // No quoting is supported, so separators/newlines inside a cell would corrupt the file.
  if (text.find_first_of(",\r\n") != std::string::npos) {
    throw CsvError(path + ": " + what + " '" + text +
                   "' contains a comma or newline; CSV quoting is not supported, rename it");
  }
}

}  // namespace

CsvTable CsvTable::read(const std::string& path) {
  if (path.empty()) throw CsvError("an empty CSV path (an unset variable?); pass the path of a .csv file");
  // ifstream happily "opens" a directory and then reads nothing; say so plainly.
  std::error_code ec;
  if (std::filesystem::is_directory(path, ec)) {
    throw CsvError(path + ": is a directory, not a CSV file; pass the path of a .csv file");
  }
  // A device or pipe may never end (/dev/zero): CSV inputs are files.
  if (std::filesystem::exists(path, ec) && !std::filesystem::is_regular_file(path, ec))
    throw CsvError(path + ": is not a regular file; pass the path of a .csv file");
  std::ifstream in(path, std::ios::binary);
  if (!in) {
    int err = errno;
    throw CsvError(path + ": cannot open file (" + errno_text(err) +
                   "); check the path exists and is readable");
  }
  std::ostringstream ss;
  ss << in.rdbuf();
  if (in.bad()) {
    throw CsvError(path + ": read error; check the file is a readable regular file");
  }
  return parse(ss.str(), path);
}

CsvTable CsvTable::parse(const std::string& text, const std::string& source_name) {
  CsvTable t;
  t.source_ = source_name;

  // A UTF-8 byte-order mark (spreadsheets write one) is not part of the first column's name.
  // UTF-16 would read as a NUL between every character: refused with the fix.
  std::size_t start = 0;
  if (text.compare(0, 3, "\xEF\xBB\xBF") == 0) start = 3;
  if (text.compare(0, 2, "\xFF\xFE") == 0 || text.compare(0, 2, "\xFE\xFF") == 0)
    throw CsvError(source_name + ": is UTF-16 text (byte-order mark); save it as UTF-8 (or ASCII) CSV");

  // Split into lines, tolerating \r\n; record 1-based line numbers.
  std::vector<std::string> lines;
  while (start < text.size()) {
    std::size_t nl = text.find('\n', start);
    std::size_t end = (nl == std::string::npos) ? text.size() : nl;
    std::size_t len = end - start;
    if (len > 0 && text[end - 1] == '\r') --len;
    lines.push_back(text.substr(start, len));
    // A carriage return left inside a line: the file ends its lines with a bare CR (classic
    // Mac), which would read as one long line with garbled cells.
    if (lines.back().find('\r') != std::string::npos)
      throw CsvError(source_name + ":" + std::to_string(lines.size()) +
                     ": a carriage return inside the line (lines ended by CR alone?); save the file with LF or CRLF "
                     "line ends");
    if (nl == std::string::npos) break;
    start = nl + 1;
  }
  // Trailing blank lines are common editor/writer artefacts; drop them.
  while (!lines.empty() && trim(lines.back()).empty()) lines.pop_back();

  if (lines.empty()) {
    throw CsvError(source_name + ": file is empty; expected a header row of column names");
  }
  if (trim(lines[0]).empty()) {
    throw CsvError(source_name + ":1: no header row (first line is blank); put column names on line 1");
  }

  for (const std::string& raw : split_line(lines[0])) t.header_.push_back(trim(raw));
  for (std::size_t c = 0; c < t.header_.size(); ++c) {
    const std::string& name = t.header_[c];
    if (name.empty()) {
      throw CsvError(source_name + ":1: column " + std::to_string(c + 1) +
                     " has an empty name; give every header cell a name");
    }
    if (!t.index_.emplace(name, c).second) {
      throw CsvError(source_name + ":1: duplicate column name '" + name +
                     "'; column names must be unique");
    }
  }

  const std::size_t ncol = t.header_.size();
  t.cells_.reserve(lines.size() - 1);
  t.line_of_row_.reserve(lines.size() - 1);
  for (std::size_t i = 1; i < lines.size(); ++i) {
    std::vector<std::string> row = split_line(lines[i]);
    if (row.size() != ncol) {
      throw CsvError(source_name + ":" + std::to_string(i + 1) + ": row has " +
                     std::to_string(row.size()) + " cells but the header has " +
                     std::to_string(ncol) + "; fix the row so every line has " +
                     std::to_string(ncol) + " comma-separated cells");
    }
    t.cells_.push_back(std::move(row));
    t.line_of_row_.push_back(i + 1);
  }
  return t;
}

const std::string& CsvTable::source() const { return source_; }
const std::vector<std::string>& CsvTable::header() const { return header_; }
std::size_t CsvTable::rows() const { return cells_.size(); }

bool CsvTable::has_column(const std::string& name) const { return index_.count(name) != 0; }

std::size_t CsvTable::column_index(const std::string& name) const {
  auto it = index_.find(name);
  if (it == index_.end()) {
    throw CsvError(source_ + ": no column '" + name + "' (columns: " + join(header_) + ")");
  }
  return it->second;
}

std::vector<double> CsvTable::numeric(const std::string& name) const {
  const std::size_t c = column_index(name);
  std::vector<double> out;
  out.reserve(cells_.size());
  for (std::size_t r = 0; r < cells_.size(); ++r) {
    const std::string text = trim(cells_[r][c]);
    const char* begin = text.c_str();
    char* end = nullptr;
    // strtod (not from_chars) so "+1", "infinity", hex floats etc. are accepted;
    // overflow to +-inf or underflow to denormal/0 is still a valid number.
    double v = text.empty() ? 0.0 : std::strtod(begin, &end);
    if (text.empty() || end != begin + text.size()) {
      throw CsvError(source_ + ":" + std::to_string(line_of_row_[r]) + ": column '" + name +
                     "' (column " + std::to_string(c + 1) + ") has non-numeric value '" +
                     cells_[r][c] + "'; expected a number such as 1.5, -2e-3, nan or inf");
    }
    out.push_back(v);
  }
  return out;
}

std::vector<double> CsvTable::finite(const std::string& name) const {
  std::vector<double> out = numeric(name);
  for (std::size_t r = 0; r < out.size(); ++r)
    if (!std::isfinite(out[r]))
      throw CsvError(source_ + ":" + std::to_string(line_of_row_[r]) + ": column '" + name + "' is '" +
                     trim(cells_[r][index_.at(name)]) + "'; give a finite number");
  return out;
}

std::size_t CsvTable::line_of_row(std::size_t row) const { return row < line_of_row_.size() ? line_of_row_[row] : 0; }

const std::string& CsvTable::cell(std::size_t row, std::size_t col) const {
  if (row >= cells_.size() || col >= header_.size()) {
    throw CsvError(source_ + ": cell(" + std::to_string(row) + ", " + std::to_string(col) +
                   ") out of range (table has " + std::to_string(cells_.size()) + " rows, " +
                   std::to_string(header_.size()) + " columns)");
  }
  return cells_[row][col];
}

std::string format_double(double v) {
  if (std::isnan(v)) return "nan";
  if (std::isinf(v)) return v > 0 ? "inf" : "-inf";
  char buf[64];
  auto res = std::to_chars(buf, buf + sizeof buf, v);
  // 64 chars always suffice for the shortest double form; guard anyway.
  if (res.ec != std::errc()) throw CsvError("format_double: to_chars failed");
  return std::string(buf, res.ptr);
}

void write_csv(const std::string& path, const std::vector<std::string>& header,
               const std::vector<std::vector<double>>& columns) {
  write_csv(path, header, columns, {}, {});
}

void write_csv(const std::string& path, const std::vector<std::string>& header,
               const std::vector<std::vector<double>>& columns,
               const std::vector<std::string>& string_header,
               const std::vector<std::vector<std::string>>& string_columns) {
  if (header.size() != columns.size()) {
    throw CsvError(path + ": header has " + std::to_string(header.size()) + " names but " +
                   std::to_string(columns.size()) + " numeric columns were given; pass one name per column");
  }
  if (string_header.size() != string_columns.size()) {
    throw CsvError(path + ": string header has " + std::to_string(string_header.size()) +
                   " names but " + std::to_string(string_columns.size()) +
                   " string columns were given; pass one name per column");
  }
  if (header.empty() && string_header.empty()) {
    throw CsvError(path + ": no columns to write; pass at least one column");
  }

  // Row count comes from the first column of either kind; all must match.
  const std::size_t nrows = !columns.empty() ? columns[0].size() : string_columns[0].size();
  auto check_len = [&](const std::string& name, std::size_t len) {
    if (len != nrows) {
      throw CsvError(path + ": column '" + name + "' has " + std::to_string(len) +
                     " rows but expected " + std::to_string(nrows) + "; all columns must have equal length");
    }
  };
  for (std::size_t c = 0; c < columns.size(); ++c) check_len(header[c], columns[c].size());
  for (std::size_t c = 0; c < string_columns.size(); ++c) check_len(string_header[c], string_columns[c].size());

  for (const auto& h : header) check_cell_text(path, "column name", h);
  for (const auto& h : string_header) check_cell_text(path, "column name", h);
  for (const auto& col : string_columns)
    for (const auto& s : col) check_cell_text(path, "value", s);

  std::string out;
  out.reserve((nrows + 1) * (columns.size() * 12 + string_columns.size() * 8 + 1));
  bool first = true;
  for (const auto& h : header) { if (!first) out += ','; out += h; first = false; }
  for (const auto& h : string_header) { if (!first) out += ','; out += h; first = false; }
  out += '\n';
  for (std::size_t r = 0; r < nrows; ++r) {
    first = true;
    for (const auto& col : columns) { if (!first) out += ','; out += format_double(col[r]); first = false; }
    for (const auto& col : string_columns) { if (!first) out += ','; out += col[r]; first = false; }
    out += '\n';
  }

  try {
    write_file_atomic(path, out);
  } catch (const FileWriteError& e) {
    throw CsvError(e.what());
  }
}

}  // namespace f16race::io
