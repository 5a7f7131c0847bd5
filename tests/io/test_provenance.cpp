// Provenance in reports: the build's commit and the CPU's name.
#include <gtest/gtest.h>

#include <cctype>
#include <string>

#include "io/provenance.hpp"

namespace f16race::io {
namespace {

// A git checkout gives 12 hex digits, "-dirty" when tracked files differ; a source tarball says
// it is not a checkout. Never empty, never a stale placeholder.
TEST(Provenance, BuildCommitIsAnAbbreviatedHashOrSaysWhyNot) {
  const std::string c = build_commit();
  if (c.rfind("unknown", 0) == 0) return;
  ASSERT_GE(c.size(), 12u);
  for (std::size_t k = 0; k < 12; ++k) EXPECT_TRUE(std::isxdigit(static_cast<unsigned char>(c[k]))) << c;
  const std::string rest = c.substr(12);
  EXPECT_TRUE(rest.empty() || rest == "-dirty") << c;
}

TEST(Provenance, CpuModelNamesTheProcessorWithFamilyAndModel) {
  const std::string m = cpu_model();
  ASSERT_FALSE(m.empty());
  if (m != "unknown CPU") {
    EXPECT_NE(m.find("(family "), std::string::npos) << m;
  }
}

}  // namespace
}  // namespace f16race::io
