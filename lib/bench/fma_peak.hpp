#pragma once
// The machine's floating-point ceiling, measured: chains of independent fused multiply-adds in
// the widest vectors this CPU runs (AVX-512, else AVX2+FMA, else SSE2 multiply and add), on every
// OpenMP thread at once. The roofline every `bench` figure is read against: a network's GFLOP/s as
// a share of the float peak, the simulator's against the double one. Measured whatever the build's
// numeric mode, since the peak is the CPU's, not the build's.
namespace f16race::bench {

struct FmaPeak {
  double f32_gflops = 0.0;  // median over the repeats
  double f64_gflops = 0.0;
  const char* isa = "";     // "avx512", "avx2", "sse2"
  int threads = 0;
};

// `threads` OpenMP threads (one parallel region per timed run), each timed run ~20 ms.
FmaPeak measure_fma_peak(int threads, int repeats);

}  // namespace f16race::bench
