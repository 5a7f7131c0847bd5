#pragma once
// Where a result comes from: the commit this binary was built from and the CPU it runs on, for
// every report and benchmark that quotes numbers (docs/performance.md).
#include <string>

namespace f16race::io {

// The sources' commit at build time (git rev-parse --short=12), with "-dirty" when tracked files
// had uncommitted changes; written by cmake/write_build_commit.cmake at every build.
const char* build_commit();

// "AMD EPYC 7763 64-Core Processor (family 25 model 1)" from /proc/cpuinfo: the model name and,
// as some virtual machines report only a vendor name, the family and model numbers.
std::string cpu_model();

// The kernel set OpenBLAS chose for this CPU ("SkylakeX", "Haswell", "Prescott" ...), which
// decides how fast every LibTorch GEMM runs; "" when the BLAS in use is not OpenBLAS.
std::string blas_core();

}  // namespace f16race::io
