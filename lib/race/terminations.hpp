#pragma once
// Why aircraft leave a race: the causes, and the per-step check of one env's live aircraft
// against the race's limits (altitude, load, turn rate, tube, Mach, the simulator's envelope).
// Collisions between aircraft: race/collisions.hpp.
#include <cstdint>

#include "dynamics/f16_batch.hpp"
#include "race/race_config.hpp"

namespace f16race::race {

// Why an aircraft left the race. Each is counted separately in StepStats.
enum TerminationCause : std::int8_t {
  kCauseNone = 0,
  kCauseCollision = 1,      // with an opponent
  kCauseAltitude = 2,
  kCauseLoad = 3,
  kCauseTurnRate = 4,
  kCauseTube = 5,
  kCauseSimulator = 6,      // the flight model's envelope or a non-finite state
  kCauseTeamCollision = 7,  // with a teammate (counted before an opponent in the same step)
  kCauseEnvelope = 8,       // faster than race.mach_max, where the aero data end
  kNumCauses = 9
};
const char* cause_name(int cause);

// One env's aircraft [base, base + n_agent) after the flight step: cause[a] becomes why live
// aircraft a is out this step (the first limit broken, in the order above), else stays as it
// was. The per-aircraft arrays are the env's slices (index a); tube_out_s[a] (time outside the
// tube) advances for the live ones.
void find_terminations(const RaceConfig& c, const dynamics::F16Batch& sim, int base, int n_agent,
                       const std::uint8_t* alive, const double* dist_ft, const double* radius_ft, double* tube_out_s,
                       std::int8_t* cause);

}  // namespace f16race::race
