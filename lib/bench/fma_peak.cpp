#include "bench/fma_peak.hpp"

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

// One body for every width and precision, in GCC's vector types: `acc * m + a` contracts to one
// FMA where the caller's target has FMA (the project builds with contraction on), else stays a
// multiply and an add, the 2 flops an FMA counts.
template <typename T, int W>
using Vec [[gnu::vector_size(sizeof(T) * W)]] = T;

template <typename T, int W, int N>
[[gnu::always_inline]] inline T chains() {
  Vec<T, W> acc[N];
  const Vec<T, W> m = Vec<T, W>{} + static_cast<T>(0.999999), a = Vec<T, W>{} + static_cast<T>(1e-7);
  for (int k = 0; k < N; ++k) acc[k] = Vec<T, W>{} + static_cast<T>(k);
  for (std::int64_t i = 0; i < kIters; ++i)
    for (int k = 0; k < N; ++k) acc[k] = acc[k] * m + a;
  Vec<T, W> s = acc[0];
  for (int k = 1; k < N; ++k) s += acc[k];
  return s[0] + s[W - 1];  // used, so the loop stays
}

// The same body compiled for each instruction set the CPU may have.
__attribute__((target("avx512f"))) float chains_avx512_f32() { return chains<float, 16, kChainsAvx512>(); }
__attribute__((target("avx512f"))) double chains_avx512_f64() { return chains<double, 8, kChainsAvx512>(); }
__attribute__((target("avx2,fma"))) float chains_avx2_f32() { return chains<float, 8, kChainsAvx2>(); }
__attribute__((target("avx2,fma"))) double chains_avx2_f64() { return chains<double, 4, kChainsAvx2>(); }
float chains_sse2_f32() { return chains<float, 4, 16>(); }
double chains_sse2_f64() { return chains<double, 2, 16>(); }

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
    p.f32_gflops = peak_of(chains_avx512_f32, threads, repeats, 2.0 * 16 * kChainsAvx512 * steps);
    p.f64_gflops = peak_of(chains_avx512_f64, threads, repeats, 2.0 * 8 * kChainsAvx512 * steps);
  } else if (__builtin_cpu_supports("avx2") && __builtin_cpu_supports("fma")) {
    p.isa = "avx2";
    p.f32_gflops = peak_of(chains_avx2_f32, threads, repeats, 2.0 * 8 * kChainsAvx2 * steps);
    p.f64_gflops = peak_of(chains_avx2_f64, threads, repeats, 2.0 * 4 * kChainsAvx2 * steps);
  } else {
    p.isa = "sse2";
    p.f32_gflops = peak_of(chains_sse2_f32, threads, repeats, 2.0 * 4 * 16 * steps);
    p.f64_gflops = peak_of(chains_sse2_f64, threads, repeats, 2.0 * 2 * 16 * steps);
  }
  return p;
}

}  // namespace f16race::bench
