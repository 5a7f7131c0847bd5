#pragma once
// The networks' matrix products as kernels of the project's own, with the same bits at every
// vector width: each element of C is one chain of fused multiply-adds along the inner dimension in
// index order, starting from its bias (or 0), and the vectors run across C's columns only. So the
// AVX2 copy (the reproducible build's x86-64-v3) and the AVX-512 copy, chosen at run time, give
// identical results, and so does a scalar loop of std::fma in the same order (the tests' oracle).
// OpenBLAS's kernels cannot: their blocking and summation order are per core type, which is why
// the reproducible mode pins them to Haswell's and half the width.
//
// No LibTorch and no allocation: the caller owns every buffer. Rows of C are independent, so any
// split of [0, m) over threads gives the same bits.
#include <cstdint>

namespace f16race::models::kernels {

// C(i, j) = bias[j] (or 0) + sum_{p < k} A(i, p) * B(p, j), the sum one FMA chain in p order.
// A(i, p) = a[i * a_row_stride + p * a_col_stride] (any strides: a transposed operand needs no
// copy); B(p, j) = b[p * b_row_stride + j]; C(i, j) = c[i * c_row_stride + j]. k == 0 writes the bias.
struct GemmArgs {
  int64_t m = 0, n = 0, k = 0;
  const float* a = nullptr;
  int64_t a_row_stride = 0, a_col_stride = 1;
  const float* b = nullptr;
  int64_t b_row_stride = 0;
  const float* bias = nullptr;  // [n] or nullptr
  float* c = nullptr;
  int64_t c_row_stride = 0;
};

enum class GemmIsa { kAuto, kAvx2, kAvx512 };

// Whether this CPU runs the AVX-512 copy (AVX-512 F, BW, DQ, VL, and the compiler built it).
bool avx512_gemm_available();
// The copy kAuto takes: AVX-512 where available, else AVX2.
GemmIsa gemm_isa_in_use();
const char* gemm_isa_name(GemmIsa isa);

// Rows [row_begin, row_end) of C. kAvx512 on a CPU without it throws std::runtime_error.
void fixed_order_gemm(const GemmArgs& args, int64_t row_begin, int64_t row_end, GemmIsa isa = GemmIsa::kAuto);
inline void fixed_order_gemm(const GemmArgs& args, GemmIsa isa = GemmIsa::kAuto) {
  fixed_order_gemm(args, 0, args.m, isa);
}

// out[j] = sum_{i < m} x[i * row_stride + j] in i order from 0 (a Linear layer's bias gradient),
// columns [col_begin, col_end).
void column_sums(const float* x, int64_t m, int64_t row_stride, int64_t col_begin, int64_t col_end, float* out);

// weight_t [in, out] = weight [out, in] transposed: a Linear layer's W^T, the B of its forward
// product (the backward reads W as it is).
void transpose_weight(const float* weight, int64_t out, int64_t in, float* weight_t);

// Per-copy entry points (fixed_order_gemm_avx2.cpp, fixed_order_gemm_avx512.cpp).
void fixed_order_gemm_avx2(const GemmArgs& args, int64_t row_begin, int64_t row_end);
void fixed_order_gemm_avx512(const GemmArgs& args, int64_t row_begin, int64_t row_end);

}  // namespace f16race::models::kernels
