#pragma once
// The body of fixed_order_gemm, compiled once per instruction set: fixed_order_gemm_avx2.cpp and
// fixed_order_gemm_avx512.cpp each define `struct Isa` (vector type, width, masked loads and
// stores, FMA) and then include this file. Everything here has internal linkage, so the two
// copies never share an out-of-line function compiled for the other's instructions.
//
// The register tile is kRows rows of C by kVecs vectors of columns: for each p, the kVecs vectors
// of B's row p are loaded once and each row's A(i, p) is broadcast against them, so the
// accumulators stay in registers for the whole inner dimension. Every C element is one FMA chain
// in p order, whatever the tile: the tile shapes only decide which chains run side by side.
#include <algorithm>
#include <cstdint>
#include <utility>

#include "models/kernels/fixed_order_gemm.hpp"

namespace f16race::models::kernels {
namespace {

// One tile: rows [i0, i0 + R) and NV vectors of columns from j0 (the last one masked if TAIL).
template <int R, int NV, bool TAIL>
void gemm_tile(const GemmArgs& g, int64_t i0, int64_t j0, typename Isa::Mask mask) {
  using V = typename Isa::V;
  constexpr int kW = Isa::kWidth;
  V acc[R][NV];
#pragma GCC unroll 8
  for (int v = 0; v < NV; ++v) {
    const bool masked = TAIL && v == NV - 1;
    const V start = g.bias == nullptr ? Isa::zero()
                    : masked          ? Isa::load_tail(g.bias + j0 + v * kW, mask)
                                      : Isa::load(g.bias + j0 + v * kW);
#pragma GCC unroll 8
    for (int r = 0; r < R; ++r) acc[r][v] = start;
  }
  const float* a = g.a + i0 * g.a_row_stride;
  const float* b = g.b + j0;
  const int64_t ars = g.a_row_stride, acs = g.a_col_stride, brs = g.b_row_stride;
  for (int64_t p = 0; p < g.k; ++p) {
    V bv[NV];
#pragma GCC unroll 8
    for (int v = 0; v < NV; ++v)
      bv[v] = (TAIL && v == NV - 1) ? Isa::load_tail(b + p * brs + v * kW, mask) : Isa::load(b + p * brs + v * kW);
#pragma GCC unroll 8
    for (int r = 0; r < R; ++r) {
      const V av = Isa::broadcast(a + r * ars + p * acs);
#pragma GCC unroll 8
      for (int v = 0; v < NV; ++v) acc[r][v] = Isa::fma(av, bv[v], acc[r][v]);
    }
  }
#pragma GCC unroll 8
  for (int r = 0; r < R; ++r) {
    float* c = g.c + (i0 + r) * g.c_row_stride + j0;
#pragma GCC unroll 8
    for (int v = 0; v < NV; ++v) {
      if (TAIL && v == NV - 1) Isa::store_tail(c + v * kW, acc[r][v], mask);
      else Isa::store(c + v * kW, acc[r][v]);
    }
  }
}

template <int R, int NV>
void gemm_tile_cols(const GemmArgs& g, int64_t i0, int64_t j0, int tail, typename Isa::Mask mask) {
  if (tail != 0) gemm_tile<R, NV, true>(g, i0, j0, mask);
  else gemm_tile<R, NV, false>(g, i0, j0, mask);
}

// nv vectors of columns (1..kVecs) for an R-row tile.
template <int R>
void gemm_tile_rows(const GemmArgs& g, int64_t i0, int64_t j0, int nv, int tail, typename Isa::Mask mask) {
  static_assert(Isa::kVecs >= 2 && Isa::kVecs <= 4, "tile widths 2..4 vectors");
  switch (nv) {
    case 1: gemm_tile_cols<R, 1>(g, i0, j0, tail, mask); break;
    case 2: gemm_tile_cols<R, 2>(g, i0, j0, tail, mask); break;
    case 3: if constexpr (Isa::kVecs >= 3) gemm_tile_cols<R, 3>(g, i0, j0, tail, mask); break;
    default: if constexpr (Isa::kVecs >= 4) gemm_tile_cols<R, 4>(g, i0, j0, tail, mask); break;
  }
}

template <int... Rs>
void gemm_tile_any(const GemmArgs& g, int rows, int64_t i0, int64_t j0, int nv, int tail, typename Isa::Mask mask,
                   std::integer_sequence<int, Rs...>) {
  // rows is 1..kRows: call the tile instantiated for exactly that many rows.
  ((rows == Rs + 1 ? (gemm_tile_rows<Rs + 1>(g, i0, j0, nv, tail, mask), 0) : 0), ...);
}

// Blocks of kBlockRows rows; within a block, column panels of kVecs vectors, and within a panel
// the block's row tiles: a panel of B (k x 64 floats on AVX-512) stays in L1 across the block's
// tiles, and C is written one block of rows at a time (a wide C, ES+D3's 1071-unit head, written
// a panel at a time over all rows would touch every page once per panel).
constexpr int64_t kBlockRows = 16 * Isa::kRows;

void gemm_rows(const GemmArgs& g, int64_t row_begin, int64_t row_end) {
  constexpr int64_t kPanel = int64_t{Isa::kVecs} * Isa::kWidth;
  for (int64_t block = row_begin; block < row_end; block += kBlockRows) {
    const int64_t block_end = std::min(row_end, block + kBlockRows);
    for (int64_t j0 = 0; j0 < g.n; j0 += kPanel) {
      const int64_t cols = std::min(kPanel, g.n - j0);
      const int nv = static_cast<int>((cols + Isa::kWidth - 1) / Isa::kWidth);
      const int tail = static_cast<int>(cols % Isa::kWidth);
      const typename Isa::Mask mask = Isa::mask(tail == 0 ? Isa::kWidth : tail);
      for (int64_t i0 = block; i0 < block_end; i0 += Isa::kRows) {
        const int rows = static_cast<int>(std::min<int64_t>(Isa::kRows, block_end - i0));
        gemm_tile_any(g, rows, i0, j0, nv, tail, mask, std::make_integer_sequence<int, Isa::kRows>{});
      }
    }
  }
}

}  // namespace
}  // namespace f16race::models::kernels
