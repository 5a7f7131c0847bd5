#include "models/kernels/masked_attention.hpp"

#include <algorithm>
#include <cmath>
#include <limits>

namespace f16race::models::kernels {

void masked_attention_forward(const AttentionShape& s, int64_t row_begin, int64_t row_end, const float* q,
                              const float* k, const float* v, const bool* alive, float* weights, float* attended) {
  const int64_t n = s.n_other, h = s.n_heads, dh = s.d_head, d = h * dh;
  const float scale = static_cast<float>(1.0 / std::sqrt(static_cast<double>(dh)));
  for (int64_t i = row_begin; i < row_end; ++i) {
    const bool* al = alive + i * n;
    for (int64_t hh = 0; hh < h; ++hh) {
      const float* qi = q + i * d + hh * dh;
      float* w = weights + (i * h + hh) * n;
      float* out = attended + i * d + hh * dh;
      float top = -std::numeric_limits<float>::infinity();
      for (int64_t j = 0; j < n; ++j) {
        if (!al[j]) continue;
        const float* kj = k + (i * n + j) * d + hh * dh;
        float dot = 0.0f;
        for (int64_t c = 0; c < dh; ++c) dot += kj[c] * qi[c];
        w[j] = dot * scale;
        top = std::max(top, w[j]);
      }
      for (int64_t c = 0; c < dh; ++c) out[c] = 0.0f;
      if (top == -std::numeric_limits<float>::infinity()) {  // nobody alive: no weight, no output
        for (int64_t j = 0; j < n; ++j) w[j] = 0.0f;
        continue;
      }
      float total = 0.0f;
      for (int64_t j = 0; j < n; ++j) {
        w[j] = al[j] ? std::exp(w[j] - top) : 0.0f;
        total += w[j];
      }
      const float inv_total = 1.0f / total;
      for (int64_t j = 0; j < n; ++j) {
        if (!al[j]) continue;
        w[j] *= inv_total;
        const float* vj = v + (i * n + j) * d + hh * dh;
        for (int64_t c = 0; c < dh; ++c) out[c] += w[j] * vj[c];
      }
    }
  }
}

void masked_attention_backward(const AttentionShape& s, int64_t row_begin, int64_t row_end, const float* q,
                               const float* k, const float* v, const float* weights, const float* grad_attended,
                               float* grad_q, float* grad_k, float* grad_v) {
  const int64_t n = s.n_other, h = s.n_heads, dh = s.d_head, d = h * dh;
  const float scale = static_cast<float>(1.0 / std::sqrt(static_cast<double>(dh)));
  float dw[kMaxOther];  // d loss / d weight of each key, one head at a time
  for (int64_t i = row_begin; i < row_end; ++i) {
    for (int64_t hh = 0; hh < h; ++hh) {
      const float* qi = q + i * d + hh * dh;
      const float* g = grad_attended + i * d + hh * dh;
      const float* w = weights + (i * h + hh) * n;
      float* gq = grad_q + i * d + hh * dh;
      // Softmax backward: ds_j = w_j (dw_j - sum_l w_l dw_l); dead keys have w_j = 0, so ds_j = 0.
      float w_dot_dw = 0.0f;
      for (int64_t j = 0; j < n; ++j) {
        const float* vj = v + (i * n + j) * d + hh * dh;
        float dot = 0.0f;
        for (int64_t c = 0; c < dh; ++c) dot += vj[c] * g[c];
        dw[j] = dot;
        w_dot_dw += w[j] * dot;
      }
      for (int64_t c = 0; c < dh; ++c) gq[c] = 0.0f;
      for (int64_t j = 0; j < n; ++j) {
        const float ds = w[j] * (dw[j] - w_dot_dw) * scale;
        const float* kj = k + (i * n + j) * d + hh * dh;
        float* gk = grad_k + (i * n + j) * d + hh * dh;
        float* gv = grad_v + (i * n + j) * d + hh * dh;
        for (int64_t c = 0; c < dh; ++c) {
          gq[c] += ds * kj[c];
          gk[c] = ds * qi[c];
          gv[c] = w[j] * g[c];
        }
      }
    }
  }
}

}  // namespace f16race::models::kernels
