// fixed_order_gemm's AVX2 copy (8 floats a vector, a 6 x 2-vector tile: 12 accumulators in the
// 16 registers), compiled with the build's flags (x86-64-v3 in the reproducible mode).
#include <immintrin.h>

namespace f16race::models::kernels {
namespace {

struct Isa {
  using V = __m256;
  using Mask = __m256i;
  static constexpr int kWidth = 8, kRows = 6, kVecs = 2;
  static Mask mask(int lanes) {
    return _mm256_cmpgt_epi32(_mm256_set1_epi32(lanes), _mm256_setr_epi32(0, 1, 2, 3, 4, 5, 6, 7));
  }
  static V zero() { return _mm256_setzero_ps(); }
  static V load(const float* p) { return _mm256_loadu_ps(p); }
  static V load_tail(const float* p, Mask m) { return _mm256_maskload_ps(p, m); }
  static V broadcast(const float* p) { return _mm256_broadcast_ss(p); }
  static V fma(V a, V b, V c) { return _mm256_fmadd_ps(a, b, c); }
  static void store(float* p, V v) { _mm256_storeu_ps(p, v); }
  static void store_tail(float* p, V v, Mask m) { _mm256_maskstore_ps(p, m, v); }
};

}  // namespace
}  // namespace f16race::models::kernels

#include "models/kernels/fixed_order_gemm_body.hpp"

namespace f16race::models::kernels {

void fixed_order_gemm_avx2(const GemmArgs& args, int64_t row_begin, int64_t row_end) {
  gemm_rows(args, row_begin, row_end);
}

}  // namespace f16race::models::kernels
