#pragma once
// A soak of the race env under hostile input: random, non-finite, huge and sign-flipping LL
// actions and out-of-range HL bins, checking every output buffer after every step. Used by
// `f16race bench soak` (long) and the race tests (short): the env must stay finite, freeze the
// aircraft it cannot fly (with a cause) and keep racing.
#include <cstdint>

#include "race/race_config.hpp"
#include "race/race_env.hpp"

namespace f16race::race {

struct SoakOptions {
  RaceConfig race;               // n_env, team_size, seed, ...
  std::int64_t aircraft_steps = 100'000'000;  // LL steps x aircraft to fly
  std::uint64_t seed = 1;        // of the hostile inputs
};

struct SoakResult {
  std::int64_t aircraft_steps = 0;
  std::int64_t non_finite = 0;           // non-finite values found in any output buffer
  std::int64_t out[kNumCauses] = {};     // aircraft taken out, by cause
  std::int64_t races_finished = 0;
  std::int64_t hostile_actions = 0;      // action components that were NaN, +-inf or beyond +-1e3
  double seconds = 0.0;
};

// The kinds of action an aircraft gets, drawn per aircraft and race: uniform in [-1, 1], NaN,
// +-inf, +-1e30, sign flips of full deflection every step, and a mix of all per component.
SoakResult run_soak(const SoakOptions& options);

}  // namespace f16race::race
