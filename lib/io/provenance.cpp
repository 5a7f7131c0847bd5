#include "io/provenance.hpp"

#include <dlfcn.h>

#include <fstream>

namespace f16race::io {

std::string cpu_model() {
  std::ifstream in("/proc/cpuinfo");
  std::string line, family, model, name;
  const auto value = [&]() {
    const auto p = line.find(':');
    return p == std::string::npos || p + 2 > line.size() ? std::string() : line.substr(p + 2);
  };
  while (std::getline(in, line) && (name.empty() || family.empty() || model.empty())) {
    if (name.empty() && line.rfind("model name", 0) == 0) name = value();
    else if (family.empty() && line.rfind("cpu family", 0) == 0) family = value();
    else if (model.empty() && line.rfind("model\t", 0) == 0) model = value();
  }
  if (name.empty()) return "unknown CPU";
  return family.empty() ? name : name + " (family " + family + " model " + model + ")";
}

std::string blas_core() {
  using CoreName = char* (*)();
  // Looked up, not linked: the project does not depend on which BLAS LibTorch's alternative is.
  const auto f = reinterpret_cast<CoreName>(dlsym(RTLD_DEFAULT, "openblas_get_corename"));
  const char* name = f != nullptr ? f() : nullptr;
  return name != nullptr ? std::string(name) : std::string();
}

}  // namespace f16race::io
