#include "models/kernels/normalize_row.hpp"

#include <algorithm>

namespace f16race::models::kernels {

void normalize_row(const NormTerms& t, const float* x, bool keep, float* out) {
  if (!keep) {
    std::fill(out, out + t.d, 0.0f);
    return;
  }
  const float lo = -t.clip, hi = t.clip;
  for (int64_t c = 0; c < t.d; ++c) out[c] = std::min(std::max((x[c] - t.mean[c]) * t.inv_std[c], lo), hi);
}

}  // namespace f16race::models::kernels
