#pragma once
// The chunks of one gradient step, run concurrently: PPO's and Expected SARSA's minibatches are
// cut into a fixed number of chunks (fixed by the config, never by the thread count), each
// chunk's gradient computed on its own, summed in chunk order, so a step is the same bits at
// any thread count.
#include <omp.h>

#include <algorithm>
#include <chrono>
#include <cstdint>
#include <exception>

namespace f16race::agents {

// run(c) for every chunk c: on the OpenMP threads when there are several chunks (LibTorch ops
// inside a parallel region run single-threaded, so the two never nest), else inline with
// LibTorch's own intra-op threads. The first exception is rethrown here.
//
// Returns the call's wall time beyond an even split of its chunks' own run times over the threads
// that ran them (the slower core's lead at the end, the fork and join; 0 when run inline). A step's
// two equal chunks finish up to ~25 % apart on the 2-vCPU VMs, one core being slower for whole runs:
// `bench train` reports the sum (docs/performance.md).
template <class Run>
double run_chunks(int64_t n_chunks, const Run& run) {
  if (n_chunks == 1 || omp_get_max_threads() == 1) {
    for (int64_t c = 0; c < n_chunks; ++c) run(c);
    return 0.0;
  }
  using Clock = std::chrono::steady_clock;
  const auto seconds = [](Clock::time_point a, Clock::time_point b) { return std::chrono::duration<double>(b - a).count(); };
  std::exception_ptr error;
  double busy_s = 0.0;
  int team = 1;
  const auto start = Clock::now();
#pragma omp parallel reduction(+ : busy_s)
  {
#pragma omp single nowait
    team = omp_get_num_threads();
#pragma omp for schedule(dynamic, 1) nowait
    for (int64_t c = 0; c < n_chunks; ++c) {
      const auto t0 = Clock::now();
      try {
        run(c);
      } catch (...) {
#pragma omp critical(f16race_ppo_chunk_error)
        if (!error) error = std::current_exception();
      }
      busy_s += seconds(t0, Clock::now());
    }
  }
  const double wall_s = seconds(start, Clock::now());
  if (error) std::rethrow_exception(error);
  return std::max(0.0, wall_s - busy_s / static_cast<double>(std::min<int64_t>(team, n_chunks)));
}

}  // namespace f16race::agents
