// agents::run_chunks: every chunk runs once, a chunk's exception comes back, and the time it
// reports (bench train's PPO and ES "chunk wait") is the call's wall time beyond an even split of
// the chunks' run times over the threads: half the gap between two unequal chunks, at least.
#include <gtest/gtest.h>
#include <omp.h>

#include <atomic>
#include <chrono>
#include <functional>
#include <stdexcept>
#include <thread>
#include <vector>

#include "agents/concurrent_chunks.hpp"

namespace f16race::agents {
namespace {

struct Threads {  // sets the OpenMP thread count for one test, restores it after
  explicit Threads(int n) : saved(omp_get_max_threads()) { omp_set_num_threads(n); }
  ~Threads() { omp_set_num_threads(saved); }
  int saved;
};

double seconds_of(const std::function<void()>& f) {
  const auto t0 = std::chrono::steady_clock::now();
  f();
  return std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
}

TEST(ConcurrentChunks, EveryChunkRunsOnceAndAnErrorComesBack) {
  for (int threads : {1, 2}) {
    Threads t(threads);
    std::vector<std::atomic<int>> runs(7);
    run_chunks(7, [&](int64_t c) { runs[static_cast<std::size_t>(c)] += 1; });
    for (const auto& r : runs) EXPECT_EQ(r.load(), 1) << threads << " threads";
    EXPECT_THROW(run_chunks(3,
                            [](int64_t c) {
                              if (c == 1) throw std::runtime_error("chunk 1");
                            }),
                 std::runtime_error);
  }
}

TEST(ConcurrentChunks, WaitIsAtLeastHalfTheGapBetweenTwoChunks) {
  using std::chrono::milliseconds;
  Threads t(2);
  // Chunk 0 runs >= 60 ms and chunk 1 ~0: whoever runs them, the wall time is >= 60 ms against an
  // even split of <= ~30 ms per thread (one thread running both still leaves the other idle).
  double wait = 0.0;
  const double wall = seconds_of([&]() {
    wait = run_chunks(2, [](int64_t c) {
      if (c == 0) std::this_thread::sleep_for(milliseconds(60));
    });
  });
  EXPECT_GE(wait, 0.025);
  EXPECT_LE(wait, wall);
  // Equal chunks: each thread was busy >= 20 ms, so at most the rest of the call was waiting.
  double equal = -1.0;
  const double equal_wall = seconds_of([&]() {
    equal = run_chunks(2, [](int64_t) { std::this_thread::sleep_for(milliseconds(20)); });
  });
  EXPECT_LE(equal, equal_wall - 0.020 + 1e-6);
}

TEST(ConcurrentChunks, InlineRunsReportNoWait) {
  {
    Threads t(1);  // one thread: the chunks run one after the other, nobody waits
    EXPECT_EQ(run_chunks(2, [](int64_t c) {
                if (c == 0) std::this_thread::sleep_for(std::chrono::milliseconds(10));
              }),
              0.0);
  }
  Threads t(2);  // a single chunk runs inline, on LibTorch's own threads
  EXPECT_EQ(run_chunks(1, [](int64_t) { std::this_thread::sleep_for(std::chrono::milliseconds(5)); }), 0.0);
}

}  // namespace
}  // namespace f16race::agents
