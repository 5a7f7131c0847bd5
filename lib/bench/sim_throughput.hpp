#pragma once
// `bench sim` and `bench env`'s measurements: the batched simulator's RK4 aircraft-substeps per
// second, and the race env's LL steps per second against the bare simulator. The command prints them.
#include <string>

#include "dynamics/f16_batch.hpp"
#include "race/race_config.hpp"

namespace f16race::bench {

// held | gcas | waypoint (io::InputError for any other name).
dynamics::StageLaw parse_stage_law(const std::string& text);

struct SimBenchCase {
  dynamics::AeroModel model = dynamics::AeroModel::kMorelli;
  dynamics::StageLaw law = dynamics::StageLaw::kHeld;  // what sets the references at each RK stage
  int aircraft = 8192;
  int threads = 1;
  int substeps = 100;  // per timed run
  int repeats = 5;     // timed runs, after one warm-up
  double dt_s = 0.01;
};

// Median RK4 aircraft-substeps per second. The aircraft start trimmed at speeds spread over
// 450-750 ft/s and hold their trim, so none leaves the envelope. Sets the OpenMP thread count.
double sim_substeps_per_s(const SimBenchCase& c);

struct EnvRates {
  double env_steps_per_s = 0;  // median LL steps of the env (every aircraft of every race)
  double sim_steps_per_s = 0;  // median: the bare simulator doing the same RK4 substeps
  int aircraft = 0;            // in the env
};

// `steps` LL steps per timed run, median of `repeats` after one warm-up, on `threads` threads
// (set here). The scripted pilot flies (its cost is not timed), so races run their normal course
// with terminations and resets.
EnvRates env_steps_per_s(const race::RaceConfig& cfg, int threads, int steps, int repeats);

}  // namespace f16race::bench
