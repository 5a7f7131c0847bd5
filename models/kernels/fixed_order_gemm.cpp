#include "models/kernels/fixed_order_gemm.hpp"

#include <stdexcept>

namespace f16race::models::kernels {

bool avx512_gemm_available() {
#if defined(F16RACE_AVX512_GEMM)
  static const bool available = __builtin_cpu_supports("avx512f") && __builtin_cpu_supports("avx512bw") &&
                                __builtin_cpu_supports("avx512dq") && __builtin_cpu_supports("avx512vl");
  return available;
#else
  return false;
#endif
}

GemmIsa gemm_isa_in_use() { return avx512_gemm_available() ? GemmIsa::kAvx512 : GemmIsa::kAvx2; }

const char* gemm_isa_name(GemmIsa isa) {
  if (isa == GemmIsa::kAuto) isa = gemm_isa_in_use();
  return isa == GemmIsa::kAvx512 ? "avx512" : "avx2";
}

void fixed_order_gemm(const GemmArgs& args, int64_t row_begin, int64_t row_end, GemmIsa isa) {
  if (row_begin >= row_end || args.n <= 0) return;
  if (isa == GemmIsa::kAuto) isa = gemm_isa_in_use();
  if (isa == GemmIsa::kAvx512) {
    if (!avx512_gemm_available()) throw std::runtime_error("fixed_order_gemm: this CPU has no AVX-512");
    fixed_order_gemm_avx512(args, row_begin, row_end);
  } else {
    fixed_order_gemm_avx2(args, row_begin, row_end);
  }
}

void column_sums(const float* x, int64_t m, int64_t row_stride, int64_t col_begin, int64_t col_end, float* out) {
  for (int64_t j = col_begin; j < col_end; ++j) out[j] = 0.0f;
  for (int64_t i = 0; i < m; ++i) {
    const float* row = x + i * row_stride;
    for (int64_t j = col_begin; j < col_end; ++j) out[j] += row[j];
  }
}

void transpose_weight(const float* weight, int64_t out, int64_t in, float* weight_t) {
  for (int64_t o = 0; o < out; ++o)
    for (int64_t i = 0; i < in; ++i) weight_t[i * out + o] = weight[o * in + i];
}

}  // namespace f16race::models::kernels
