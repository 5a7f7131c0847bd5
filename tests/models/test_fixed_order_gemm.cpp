// The fixed-order matrix product gives one answer at every vector width: the AVX2 copy, the
// AVX-512 copy (where this CPU has it) and a scalar loop of std::fma in the same order agree bit
// for bit, over shapes with every kind of tail, transposed operands, biases and row splits. A
// double-precision product bounds the rounding.
#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <cstdint>
#include <cstring>
#include <random>
#include <stdexcept>
#include <vector>

#include "models/kernels/fixed_order_gemm.hpp"

namespace f16race::models::kernels {
namespace {

struct Case {
  int64_t m, n, k;
  bool transposed_a, with_bias;
};

struct Operands {
  std::vector<float> a, b, bias;
  GemmArgs args(const Case& c, std::vector<float>& out) {
    GemmArgs g;
    g.m = c.m;
    g.n = c.n;
    g.k = c.k;
    g.a = a.data();
    // A stored as [k, m] when transposed: A(i, p) = a[p * m + i].
    g.a_row_stride = c.transposed_a ? 1 : c.k;
    g.a_col_stride = c.transposed_a ? c.m : 1;
    g.b = b.data();
    g.b_row_stride = c.n + 3;  // B's rows padded: the kernel must not read or assume the padding
    g.bias = c.with_bias ? bias.data() : nullptr;
    out.assign(static_cast<size_t>(c.m * (c.n + 5)), -7.0f);
    g.c = out.data();
    g.c_row_stride = c.n + 5;  // C's padding must stay untouched
    return g;
  }
};

Operands random_operands(const Case& c, std::mt19937& rng) {
  std::normal_distribution<float> normal(0.0f, 1.0f);
  Operands o;
  o.a.resize(static_cast<size_t>(std::max<int64_t>(1, c.m * c.k)));
  o.b.resize(static_cast<size_t>(std::max<int64_t>(1, c.k * (c.n + 3))));
  o.bias.resize(static_cast<size_t>(c.n));
  for (auto* v : {&o.a, &o.b, &o.bias})
    for (float& x : *v) x = normal(rng);
  return o;
}

// The definition: one std::fma chain per element, in p order, from the bias.
void scalar_oracle(const GemmArgs& g) {
  for (int64_t i = 0; i < g.m; ++i)
    for (int64_t j = 0; j < g.n; ++j) {
      float acc = g.bias ? g.bias[j] : 0.0f;
      for (int64_t p = 0; p < g.k; ++p)
        acc = std::fma(g.a[i * g.a_row_stride + p * g.a_col_stride], g.b[p * g.b_row_stride + j], acc);
      g.c[i * g.c_row_stride + j] = acc;
    }
}

std::vector<Case> cases() {
  std::vector<Case> out;
  for (int64_t m : {1, 5, 6, 7, 13, 64, 459})
    for (int64_t n : {1, 3, 8, 15, 16, 17, 33, 64, 65, 129, 357})
      for (int64_t k : {0, 1, 7, 64, 101}) out.push_back({m, n, k, (m + n + k) % 2 == 0, (m + k) % 3 != 0});
  return out;
}

bool same_bits(const std::vector<float>& x, const std::vector<float>& y) {
  return x.size() == y.size() && std::memcmp(x.data(), y.data(), x.size() * sizeof(float)) == 0;
}

TEST(FixedOrderGemm, EveryCopyGivesTheScalarChainsBits) {
  std::mt19937 rng(5);
  std::vector<GemmIsa> isas{GemmIsa::kAvx2};
  if (avx512_gemm_available()) isas.push_back(GemmIsa::kAvx512);
  for (const Case& c : cases()) {
    Operands o = random_operands(c, rng);
    std::vector<float> expected;
    scalar_oracle(o.args(c, expected));
    for (GemmIsa isa : isas) {
      std::vector<float> got;
      fixed_order_gemm(o.args(c, got), isa);
      ASSERT_TRUE(same_bits(got, expected)) << gemm_isa_name(isa) << " m " << c.m << " n " << c.n << " k " << c.k
                                            << (c.transposed_a ? " A^T" : "") << (c.with_bias ? " bias" : "");
    }
  }
}

TEST(FixedOrderGemm, AnySplitOfTheRowsGivesTheSameBits) {
  std::mt19937 rng(6);
  const Case c{459, 64, 101, false, true};
  Operands o = random_operands(c, rng);
  std::vector<float> whole, pieces;
  fixed_order_gemm(o.args(c, whole));
  const GemmArgs g = o.args(c, pieces);
  for (int64_t begin = 0; begin < c.m;) {
    const int64_t end = std::min<int64_t>(c.m, begin + 1 + begin % 37);
    fixed_order_gemm(g, begin, end);
    begin = end;
  }
  EXPECT_TRUE(same_bits(whole, pieces));
}

TEST(FixedOrderGemm, StaysWithinFloatRoundingOfTheExactProduct) {
  std::mt19937 rng(7);
  const Case c{64, 65, 101, true, true};
  Operands o = random_operands(c, rng);
  std::vector<float> got;
  const GemmArgs g = o.args(c, got);
  fixed_order_gemm(g);
  double worst = 0.0;
  for (int64_t i = 0; i < c.m; ++i)
    for (int64_t j = 0; j < c.n; ++j) {
      double exact = g.bias[j], scale = std::fabs(g.bias[j]);
      for (int64_t p = 0; p < c.k; ++p) {
        const double t = double{g.a[i * g.a_row_stride + p * g.a_col_stride]} * g.b[p * g.b_row_stride + j];
        exact += t;
        scale += std::fabs(t);
      }
      worst = std::max(worst, std::fabs(got[static_cast<size_t>(i * g.c_row_stride + j)] - exact) / scale);
    }
  // A chain of 101 roundings, each at most 2^-24 of the running |sum| <= scale.
  EXPECT_LT(worst, 101 * 0x1p-24);
  EXPECT_GT(worst, 0.0);  // float arithmetic, not double
}

TEST(FixedOrderGemm, ColumnSumsAddTheRowsInOrder) {
  const std::vector<float> x{1.0f, 2.0f, 3.0f, 1e8f, -1.0f, 0.5f, -1e8f, 4.0f, 0.25f};  // [3, 3]
  std::vector<float> out(3, 9.0f);
  column_sums(x.data(), 3, 3, 0, 3, out.data());
  EXPECT_EQ(out[0], (1.0f + 1e8f) + -1e8f);  // 0 in float: the order is the rows'
  EXPECT_EQ(out[1], 2.0f - 1.0f + 4.0f);
  EXPECT_EQ(out[2], 3.0f + 0.5f + 0.25f);
  std::vector<float> part(3, 9.0f);
  column_sums(x.data(), 3, 3, 1, 2, part.data());
  EXPECT_EQ(part[0], 9.0f);
  EXPECT_EQ(part[1], out[1]);
  EXPECT_EQ(part[2], 9.0f);
}

TEST(FixedOrderGemm, TheAvx512CopyIsRefusedWhereTheCpuLacksIt) {
  if (avx512_gemm_available()) GTEST_SKIP() << "this CPU has AVX-512: the copy is tested above";
  GemmArgs g;
  g.m = g.n = g.k = 1;
  EXPECT_THROW(fixed_order_gemm(g, GemmIsa::kAvx512), std::runtime_error);
}

}  // namespace
}  // namespace f16race::models::kernels
