#pragma once

#include <cstddef>
#include <stdexcept>
#include <string>
#include <unordered_map>
#include <vector>

#include "io/input_error.hpp"

namespace f16race::io {

// Thrown for any bad input; what() is one line naming the file (and line/column
// where known) and how to fix it.
class CsvError : public InputError {
 public:
  using InputError::InputError;
};

// A CSV file with a header row, kept as text cells; numeric columns are
// converted on request so string columns ('mode', 'case') can coexist.
class CsvTable {
 public:
  static CsvTable read(const std::string& path);
  static CsvTable parse(const std::string& text, const std::string& source_name);

  const std::string& source() const;
  const std::vector<std::string>& header() const;
  std::size_t rows() const;
  bool has_column(const std::string& name) const;
  std::size_t column_index(const std::string& name) const;
  // nan and inf cells are numbers here (a metrics file leaves them where nothing was measured).
  std::vector<double> numeric(const std::string& name) const;
  // numeric(), refusing a nan or infinite cell (or one that overflows a double) naming the file,
  // its line and the column: for inputs a computation starts from.
  std::vector<double> finite(const std::string& name) const;
  // The 1-based file line of data row `row` (the header is line 1), for messages.
  std::size_t line_of_row(std::size_t row) const;
  const std::string& cell(std::size_t row, std::size_t col) const;

 private:
  std::string source_;
  std::vector<std::string> header_;
  std::unordered_map<std::string, std::size_t> index_;
  // Row-major cells; line_of_row_ keeps the 1-based file line for messages.
  std::vector<std::vector<std::string>> cells_;
  std::vector<std::size_t> line_of_row_;
};

// Writes a CSV atomically (temp file + fsync + rename), creating parent
// directories. columns[c][r]; all columns must have equal length.
void write_csv(const std::string& path, const std::vector<std::string>& header,
               const std::vector<std::vector<double>>& columns);

// Same, with string columns appended after the numeric ones.
void write_csv(const std::string& path, const std::vector<std::string>& header,
               const std::vector<std::vector<double>>& columns,
               const std::vector<std::string>& string_header,
               const std::vector<std::vector<std::string>>& string_columns);

// Shortest text that round-trips to the same double; "nan"/"inf"/"-inf".
std::string format_double(double v);

}  // namespace f16race::io
