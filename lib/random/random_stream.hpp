#pragma once
// A small counter-free random stream with a fixed, documented algorithm (SplitMix64, Steele et
// al. 2014), so the same (seed, stream id) gives the same numbers on every machine and compiler.
// std:: distributions are implementation-defined, which would make tracks differ across
// standard libraries. Header-only, with no project dependency: the race task, training and
// evaluation statistics all draw from it.
#include <cmath>
#include <cstdint>

namespace f16race {

class RandomStream {
 public:
  // Independent streams per (seed, id): env e of a run uses id e, so results do not depend on
  // which thread handles which env.
  RandomStream(std::uint64_t seed, std::uint64_t stream_id) : state_(mix(seed ^ mix(stream_id + 0x5851F42D4C957F2DULL))) {}

  std::uint64_t next_u64() {
    std::uint64_t z = (state_ += 0x9E3779B97F4A7C15ULL);
    return mix_step(z);
  }
  // Uniform in [0, 1) with 53 random bits.
  double uniform() { return static_cast<double>(next_u64() >> 11) * 0x1.0p-53; }
  double uniform(double lo, double hi) { return lo + (hi - lo) * uniform(); }
  // Uniform integer in [0, n).
  int below(int n) { return static_cast<int>(uniform() * n); }

  std::uint64_t state() const { return state_; }
  void set_state(std::uint64_t s) { state_ = s; }

 private:
  static std::uint64_t mix_step(std::uint64_t z) {
    z = (z ^ (z >> 30)) * 0xBF58476D1CE4E5B9ULL;
    z = (z ^ (z >> 27)) * 0x94D049BB133111EBULL;
    return z ^ (z >> 31);
  }
  static std::uint64_t mix(std::uint64_t z) { return mix_step(z + 0x9E3779B97F4A7C15ULL); }
  std::uint64_t state_;
};

}  // namespace f16race
