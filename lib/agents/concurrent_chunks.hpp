#pragma once
// The chunks of one gradient step, run concurrently: PPO's and Expected SARSA's minibatches are
// cut into a fixed number of chunks (fixed by the config, never by the thread count), each
// chunk's gradient computed on its own, summed in chunk order, so a step is the same bits at
// any thread count.
#include <omp.h>

#include <cstdint>
#include <exception>

namespace f16race::agents {

// run(c) for every chunk c: on the OpenMP threads when there are several chunks (LibTorch ops
// inside a parallel region run single-threaded, so the two never nest), else inline with
// LibTorch's own intra-op threads. The first exception is rethrown here.
template <class Run>
void run_chunks(int64_t n_chunks, const Run& run) {
  if (n_chunks == 1 || omp_get_max_threads() == 1) {
    for (int64_t c = 0; c < n_chunks; ++c) run(c);
    return;
  }
  std::exception_ptr error;
#pragma omp parallel for schedule(dynamic, 1)
  for (int64_t c = 0; c < n_chunks; ++c) {
    try {
      run(c);
    } catch (...) {
#pragma omp critical(f16race_ppo_chunk_error)
      if (!error) error = std::current_exception();
    }
  }
  if (error) std::rethrow_exception(error);
}

}  // namespace f16race::agents
