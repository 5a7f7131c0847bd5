#pragma once
// One observation row normalised with RunningNorm's statistics, in float:
// clamp((x - mean) * inv_std, -clip, clip) per feature. The one place of that arithmetic, for
// RunningNorm's own normalisation and for AttentionMlpForward, which normalises its blocks' rows on the
// threads (models/running_norm.hpp, models/kernels/attention_mlp_forward.hpp).
#include <cstdint>

namespace f16race::models::kernels {

struct NormTerms {
  const float* mean = nullptr;     // [d] the statistics' mean, rounded to float
  const float* inv_std = nullptr;  // [d] float(1 / sqrt(var + eps))
  float clip = 10.0f;
  int64_t d = 0;
};

// out [d] from x [d]; `keep` false writes zeros (a dead aircraft's ado row).
void normalize_row(const NormTerms& t, const float* x, bool keep, float* out);

}  // namespace f16race::models::kernels
