#include "bench/fma_peak.hpp"

#include <immintrin.h>
#include <omp.h>

#include <cstdint>

#include "bench/timing.hpp"

namespace f16race::bench {

namespace {

// Independent chains hide the FMA latency (4 cycles) behind two issue ports: 8 would do; 12 and 16
// leave slack, within the 16 ymm and 32 zmm registers with the two constants.
constexpr int kChainsAvx2 = 12;
constexpr int kChainsAvx512 = 16;
constexpr std::int64_t kIters = 1 << 18;  // ~10-20 ms a thread

template <int N>
__attribute__((target("avx512f"))) float chains_avx512_f32() {
  __m512 acc[N];
  const __m512 m = _mm512_set1_ps(0.999999f), a = _mm512_set1_ps(1e-7f);
  for (int k = 0; k < N; ++k) acc[k] = _mm512_set1_ps(static_cast<float>(k));
  for (std::int64_t i = 0; i < kIters; ++i)
    for (int k = 0; k < N; ++k) acc[k] = _mm512_fmadd_ps(acc[k], m, a);
  __m512 s = acc[0];
  for (int k = 1; k < N; ++k) s = _mm512_add_ps(s, acc[k]);
  alignas(64) float out[16];  // a store, not _mm512_reduce_add_ps: GCC 12 warns inside that one
  _mm512_store_ps(out, s);
  return out[0] + out[15];  // used, so the loop stays
}

template <int N>
__attribute__((target("avx512f"))) double chains_avx512_f64() {
  __m512d acc[N];
  const __m512d m = _mm512_set1_pd(0.999999), a = _mm512_set1_pd(1e-7);
  for (int k = 0; k < N; ++k) acc[k] = _mm512_set1_pd(static_cast<double>(k));
  for (std::int64_t i = 0; i < kIters; ++i)
    for (int k = 0; k < N; ++k) acc[k] = _mm512_fmadd_pd(acc[k], m, a);
  __m512d s = acc[0];
  for (int k = 1; k < N; ++k) s = _mm512_add_pd(s, acc[k]);
  alignas(64) double out[8];
  _mm512_store_pd(out, s);
  return out[0] + out[7];
}

template <int N>
__attribute__((target("avx2,fma"))) float chains_avx2_f32() {
  __m256 acc[N];
  const __m256 m = _mm256_set1_ps(0.999999f), a = _mm256_set1_ps(1e-7f);
  for (int k = 0; k < N; ++k) acc[k] = _mm256_set1_ps(static_cast<float>(k));
  for (std::int64_t i = 0; i < kIters; ++i)
    for (int k = 0; k < N; ++k) acc[k] = _mm256_fmadd_ps(acc[k], m, a);
  __m256 s = acc[0];
  for (int k = 1; k < N; ++k) s = _mm256_add_ps(s, acc[k]);
  alignas(32) float out[8];
  _mm256_store_ps(out, s);
  return out[0] + out[7];
}

template <int N>
__attribute__((target("avx2,fma"))) double chains_avx2_f64() {
  __m256d acc[N];
  const __m256d m = _mm256_set1_pd(0.999999), a = _mm256_set1_pd(1e-7);
  for (int k = 0; k < N; ++k) acc[k] = _mm256_set1_pd(static_cast<double>(k));
  for (std::int64_t i = 0; i < kIters; ++i)
    for (int k = 0; k < N; ++k) acc[k] = _mm256_fmadd_pd(acc[k], m, a);
  __m256d s = acc[0];
  for (int k = 1; k < N; ++k) s = _mm256_add_pd(s, acc[k]);
  alignas(32) double out[4];
  _mm256_store_pd(out, s);
  return out[0] + out[3];
}

// Without FMA: a multiply and an add per step, the 2 flops an FMA counts.
template <typename T, int N>
T chains_sse2() {
  T acc[N];
  for (int k = 0; k < N; ++k) acc[k] = static_cast<T>(k);
  const T m = static_cast<T>(0.999999), a = static_cast<T>(1e-7);
  for (std::int64_t i = 0; i < kIters; ++i)
    for (int k = 0; k < N; ++k) acc[k] = acc[k] * m + a;
  T s = 0;
  for (int k = 0; k < N; ++k) s += acc[k];
  return s;
}

// GFLOP/s of `chains` run once on each of `threads` threads at once: 2 flops per lane per FMA.
template <typename F>
double peak_of(F chains, int threads, int repeats, double flops_per_thread) {
  volatile double sink = 0.0;
  const double s = time_median_s(
      [&]() {
#pragma omp parallel num_threads(threads)
        {
          const double v = static_cast<double>(chains());
#pragma omp critical
          sink = sink + v;
        }
      },
      repeats);
  return flops_per_thread * threads / s * 1e-9;
}

}  // namespace

FmaPeak measure_fma_peak(int threads, int repeats) {
  FmaPeak p;
  p.threads = threads;
  __builtin_cpu_init();
  const double steps = static_cast<double>(kIters);
  if (__builtin_cpu_supports("avx512f")) {
    p.isa = "avx512";
    p.f32_gflops = peak_of(chains_avx512_f32<kChainsAvx512>, threads, repeats, 2.0 * 16 * kChainsAvx512 * steps);
    p.f64_gflops = peak_of(chains_avx512_f64<kChainsAvx512>, threads, repeats, 2.0 * 8 * kChainsAvx512 * steps);
  } else if (__builtin_cpu_supports("avx2") && __builtin_cpu_supports("fma")) {
    p.isa = "avx2";
    p.f32_gflops = peak_of(chains_avx2_f32<kChainsAvx2>, threads, repeats, 2.0 * 8 * kChainsAvx2 * steps);
    p.f64_gflops = peak_of(chains_avx2_f64<kChainsAvx2>, threads, repeats, 2.0 * 4 * kChainsAvx2 * steps);
  } else {
    p.isa = "sse2";  // scalar source; the compiler vectorises what it can
    p.f32_gflops = peak_of(chains_sse2<float, 16>, threads, repeats, 2.0 * 16 * steps);
    p.f64_gflops = peak_of(chains_sse2<double, 16>, threads, repeats, 2.0 * 16 * steps);
  }
  return p;
}

}  // namespace f16race::bench
