#include "io/openmp_waits.hpp"

#include <cstdlib>

namespace f16race::io {

bool bound_openmp_spins() {
  if (std::getenv("OMP_WAIT_POLICY") != nullptr || std::getenv("GOMP_SPINCOUNT") != nullptr) return false;
  return setenv("GOMP_SPINCOUNT", kOpenmpSpinCount, 1) == 0;
}

}  // namespace f16race::io
