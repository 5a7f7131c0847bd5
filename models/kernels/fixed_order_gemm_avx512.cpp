// fixed_order_gemm's AVX-512 copy (16 floats a vector, a 6 x 4-vector tile: 24 accumulators in
// the 32 registers), compiled for x86-64-v4 whatever the build's own target, and run only where
// the CPU has it (fixed_order_gemm.cpp). Same bits as the AVX2 copy: see fixed_order_gemm.hpp.
#include "models/kernels/fixed_order_gemm.hpp"

#if defined(F16RACE_AVX512_GEMM)
#include <immintrin.h>

namespace f16race::models::kernels {
namespace {

struct Isa {
  using V = __m512;
  using Mask = __mmask16;
  static constexpr int kWidth = 16, kRows = 6, kVecs = 4;
  static Mask mask(int lanes) { return static_cast<Mask>((1u << lanes) - 1u); }
  static V zero() { return _mm512_setzero_ps(); }
  static V load(const float* p) { return _mm512_loadu_ps(p); }
  static V load_tail(const float* p, Mask m) { return _mm512_maskz_loadu_ps(m, p); }
  static V broadcast(const float* p) { return _mm512_set1_ps(*p); }
  static V fma(V a, V b, V c) { return _mm512_fmadd_ps(a, b, c); }
  static void store(float* p, V v) { _mm512_storeu_ps(p, v); }
  static void store_tail(float* p, V v, Mask m) { _mm512_mask_storeu_ps(p, m, v); }
};

}  // namespace
}  // namespace f16race::models::kernels

#include "models/kernels/fixed_order_gemm_body.hpp"

namespace f16race::models::kernels {

void fixed_order_gemm_avx512(const GemmArgs& args, int64_t row_begin, int64_t row_end) {
  gemm_rows(args, row_begin, row_end);
}

}  // namespace f16race::models::kernels

#else
#include <stdexcept>

namespace f16race::models::kernels {

void fixed_order_gemm_avx512(const GemmArgs&, int64_t, int64_t) {
  throw std::runtime_error("fixed_order_gemm: this build has no AVX-512 copy (the compiler lacks x86-64-v4)");
}

}  // namespace f16race::models::kernels
#endif
