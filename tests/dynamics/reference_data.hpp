#pragma once
// Loads the AeroBench reference files copied into tests/data (see tests/data/README.md).
#include <string>

#include "io/csv_table.hpp"

namespace f16race::test {

inline io::CsvTable load_reference(const std::string& name) {
  return io::CsvTable::read(std::string(F16RACE_TEST_DATA_DIR) + "/" + name);
}

}  // namespace f16race::test
