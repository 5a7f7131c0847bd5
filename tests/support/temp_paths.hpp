#pragma once
// One scratch path per test in the system temp folder: `f16race_<name>`, removed first together
// with the RUN.old-N folders `train --overwrite` may have left beside it. Not created (a test of
// "missing folder" needs it absent); create it where the test needs it.
#include <filesystem>
#include <string>

namespace f16race::test_support {

inline std::string fresh_temp_path(const std::string& name) {
  const std::filesystem::path p = std::filesystem::temp_directory_path() / ("f16race_" + name);
  std::filesystem::remove_all(p);
  for (int n = 1; n < 4; ++n) std::filesystem::remove_all(p.string() + ".old-" + std::to_string(n));
  return p.string();
}

}  // namespace f16race::test_support
