#include "io/numeric_mode.hpp"

#include <cstdlib>
#include <sstream>

#include "io/provenance.hpp"

#ifndef F16RACE_REPRODUCIBLE
#error "F16RACE_REPRODUCIBLE is set by CMakeLists.txt from F16RACE_ARCH"
#endif

namespace f16race::io {

NumericMode numeric_mode() { return F16RACE_REPRODUCIBLE ? NumericMode::kReproducible : NumericMode::kNative; }

const char* numeric_mode_name() { return numeric_mode() == NumericMode::kReproducible ? "reproducible" : "native"; }

namespace {

// Each library's own switch for its CPU-dependent choice. Haswell is OpenBLAS's kernel set for every
// AVX2+FMA CPU (Intel since Haswell, AMD since Zen 1); ATen's and oneDNN's AVX2 levels the same.
struct Pin {
  const char* name;
  const char* value;  // nullptr: must be unset
};
constexpr Pin kPins[] = {
    {"OPENBLAS_CORETYPE", "Haswell"},
    {"ATEN_CPU_CAPABILITY", "avx2"},
    {"DNNL_MAX_CPU_ISA", "AVX2"},
    {"ONEDNN_MAX_CPU_ISA", "AVX2"},
    {"GOTO_BLOCK_FACTOR", nullptr},  // OpenBLAS's block sizes
};

// GLIBC_TUNABLES without its glibc.cpu.* entries (hwcaps masks and the like pick libm's exp, log,
// sin ... variants): the other tunables (malloc's, say) stay the user's.
std::string without_cpu_tunables(const std::string& tunables) {
  std::string kept, item;
  std::istringstream in(tunables);
  while (std::getline(in, item, ':')) {
    if (item.empty() || item.rfind("glibc.cpu.", 0) == 0) continue;
    kept += (kept.empty() ? "" : ":") + item;
  }
  return kept;
}

}  // namespace

bool pin_numeric_environment() {
  bool changed = false;
  for (const Pin& p : kPins) {
    const char* have = std::getenv(p.name);
    if (p.value == nullptr) {
      if (have != nullptr) changed |= unsetenv(p.name) == 0;
    } else if (have == nullptr || std::string(have) != p.value) {
      changed |= setenv(p.name, p.value, 1) == 0;
    }
  }
  if (const char* t = std::getenv("GLIBC_TUNABLES")) {
    const std::string kept = without_cpu_tunables(t);
    if (kept != t) {
      changed = true;
      if (kept.empty()) unsetenv("GLIBC_TUNABLES");
      else setenv("GLIBC_TUNABLES", kept.c_str(), 1);
    }
  }
  return changed;
}

std::string numeric_mode_summary() {
  if (numeric_mode() == NumericMode::kReproducible)
    return "reproducible (x86-64-v3 kernels, OpenBLAS Haswell and ATen avx2 on every CPU: the same bytes on any "
           "x86-64 CPU with AVX2 and FMA)";
  return "native (this CPU's SIMD, OpenBLAS and ATen kernels of its choice: the bytes are this CPU's own; " +
         cpu_model() + ")";
}

RunNumerics this_numerics() {
  RunNumerics n;
  n.recorded = true;
  n.mode = numeric_mode_name();
  if (numeric_mode() == NumericMode::kNative) n.cpu = cpu_model();
  return n;
}

std::string describe(const RunNumerics& n) {
  if (!n.recorded) return "native (trained before the mode was recorded, CPU unknown)";
  return n.mode == "native" ? "native on " + n.cpu : n.mode;
}

std::string numerics_difference(const RunNumerics& a, const RunNumerics& b) {
  const bool a_repro = a.recorded && a.mode == "reproducible";
  const bool b_repro = b.recorded && b.mode == "reproducible";
  if (a_repro && b_repro) return "";
  if (!a_repro && !b_repro && a.recorded && b.recorded && !a.cpu.empty() && a.cpu == b.cpu) return "";
  return describe(a) + " against " + describe(b);
}

}  // namespace f16race::io
