// The numeric mode: the environment the reproducible mode pins, a run folder's record of its mode,
// and which records compute the same bytes.
#include <gtest/gtest.h>

#include <cstdlib>
#include <string>

#include "io/numeric_mode.hpp"

namespace f16race::io {
namespace {

std::string env_or_unset(const char* name) {
  const char* v = std::getenv(name);
  return v == nullptr ? "(unset)" : v;
}

// Every library's switch ends at its pinned value; a user's other glibc tunables stay; a second
// call finds nothing to change, so the process runs itself again at most once.
TEST(NumericMode, PinsEveryKernelChoiceAndKeepsOtherTunables) {
  setenv("OPENBLAS_CORETYPE", "SkylakeX", 1);
  setenv("ATEN_CPU_CAPABILITY", "avx512", 1);
  unsetenv("DNNL_MAX_CPU_ISA");
  setenv("ONEDNN_MAX_CPU_ISA", "AVX512_CORE", 1);
  setenv("GOTO_BLOCK_FACTOR", "50", 1);
  setenv("GLIBC_TUNABLES", "glibc.malloc.arena_max=2:glibc.cpu.hwcaps=-AVX2,-FMA:glibc.cpu.x86_rep_movsb_threshold=1", 1);
  EXPECT_TRUE(pin_numeric_environment());
  EXPECT_EQ(env_or_unset("OPENBLAS_CORETYPE"), "Haswell");
  EXPECT_EQ(env_or_unset("ATEN_CPU_CAPABILITY"), "avx2");
  EXPECT_EQ(env_or_unset("DNNL_MAX_CPU_ISA"), "AVX2");
  EXPECT_EQ(env_or_unset("ONEDNN_MAX_CPU_ISA"), "AVX2");
  EXPECT_EQ(env_or_unset("GOTO_BLOCK_FACTOR"), "(unset)");
  EXPECT_EQ(env_or_unset("GLIBC_TUNABLES"), "glibc.malloc.arena_max=2");
  EXPECT_FALSE(pin_numeric_environment());
  setenv("GLIBC_TUNABLES", "glibc.cpu.hwcaps=-AVX2", 1);
  EXPECT_TRUE(pin_numeric_environment());
  EXPECT_EQ(env_or_unset("GLIBC_TUNABLES"), "(unset)");
  EXPECT_FALSE(pin_numeric_environment());
}

RunNumerics record(const std::string& mode, const std::string& cpu) {
  RunNumerics n;
  n.recorded = true;
  n.mode = mode;
  n.cpu = cpu;
  return n;
}

// Reproducible runs agree whatever CPU trained them; native ones only on one CPU; a run from before
// the record is native on an unknown CPU, so it agrees with nothing but says why.
TEST(NumericMode, RecordsAgreeOnlyWhereTheBytesDo) {
  const RunNumerics repro_a = record("reproducible", "");
  const RunNumerics repro_b = record("reproducible", "Intel Xeon (family 6 model 167)");
  const RunNumerics native_a = record("native", "AMD EPYC (family 26 model 2)");
  const RunNumerics native_b = record("native", "Intel Xeon (family 6 model 167)");
  const RunNumerics legacy;
  EXPECT_EQ(numerics_difference(repro_a, repro_b), "");
  EXPECT_EQ(numerics_difference(native_a, native_a), "");
  EXPECT_NE(numerics_difference(native_a, native_b), "");
  EXPECT_NE(numerics_difference(repro_a, native_a), "");
  EXPECT_NE(numerics_difference(legacy, native_a), "");
  EXPECT_NE(numerics_difference(legacy, legacy), "");
  EXPECT_EQ(describe(native_b), "native on Intel Xeon (family 6 model 167)");
  EXPECT_EQ(describe(repro_b), "reproducible");
  EXPECT_NE(describe(legacy).find("before the mode was recorded"), std::string::npos);
}

// A reproducible record names no CPU (its bytes are every CPU's); a native one names this CPU.
TEST(NumericMode, ThisProcessRecordsItsModeAndOnlyANativeOneItsCpu) {
  const RunNumerics self = this_numerics();
  EXPECT_TRUE(self.recorded);
  EXPECT_EQ(self.mode, numeric_mode_name());
  EXPECT_EQ(self.cpu.empty(), numeric_mode() == NumericMode::kReproducible) << self.cpu;
  EXPECT_EQ(numerics_difference(self, self), "");
}

TEST(NumericMode, SummaryNamesTheModeAndItsScope) {
  const std::string s = numeric_mode_summary();
  EXPECT_EQ(s.rfind(numeric_mode_name(), 0), 0u) << s;
  if (numeric_mode() == NumericMode::kReproducible) EXPECT_NE(s.find("AVX2 and FMA"), std::string::npos) << s;
  else EXPECT_NE(s.find("this CPU"), std::string::npos) << s;
}

}  // namespace
}  // namespace f16race::io
