#pragma once
// How this binary computes floating point, and so whether a run's bytes depend on the CPU.
//
// The reproducible mode (F16RACE_ARCH=reproducible, the default build) compiles the project's own
// kernels for x86-64-v3 and pins every choice a library would otherwise make from the CPU or the
// environment: OpenBLAS's kernel set (read when it loads), LibTorch's capability dispatch, oneDNN's
// instruction set, glibc's CPU tunables (which pick libm's variants). The native mode
// (F16RACE_ARCH=native) compiles for this CPU's widest SIMD and leaves those choices to the CPU:
// faster, and its bytes are its CPU's own. docs/architecture.md, "Bytes that do not depend on the
// machine", lists what is pinned and why.
#include <string>

namespace f16race::io {

enum class NumericMode { kReproducible, kNative };

// Fixed at build time.
NumericMode numeric_mode();
const char* numeric_mode_name();  // "reproducible" or "native"

// The environment the reproducible mode runs in: OPENBLAS_CORETYPE=Haswell, ATEN_CPU_CAPABILITY=avx2,
// DNNL_MAX_CPU_ISA and ONEDNN_MAX_CPU_ISA=AVX2, GOTO_BLOCK_FACTOR unset, no glibc.cpu.* tunable.
// Sets whatever the process's environment does not already hold and returns true when it changed
// anything: the process must then run itself again, since OpenBLAS and glibc read theirs at load.
bool pin_numeric_environment();

// One line for --version and the bench headers, e.g. "reproducible (x86-64-v3; OpenBLAS Haswell,
// ATen avx2 kernels on every CPU)" or "native (this CPU's SIMD: AMD EPYC (family 26 model 2))".
std::string numeric_mode_summary();

// What a checkpoint records of the binary that wrote it (train/run_numerics.hpp): the mode, and for
// a native build its CPU, which decides its bytes (a reproducible run's bytes name no CPU).
struct RunNumerics {
  bool recorded = false;  // false: written before the record (by a native build, its CPU unknown)
  std::string mode;       // "reproducible" or "native"
  std::string cpu;        // native: the CPU it ran on
};

// This process's record.
RunNumerics this_numerics();

// "" when `a` and `b` compute the same bytes from the same inputs (both reproducible, or both native
// on the same CPU); otherwise a short phrase saying how they differ, e.g. "native on Intel Xeon ...
// against reproducible".
std::string numerics_difference(const RunNumerics& a, const RunNumerics& b);
// How a record reads in one line: "reproducible", "native on CPU", "native (before the record ...)".
std::string describe(const RunNumerics& n);

}  // namespace f16race::io
