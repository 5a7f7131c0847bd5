#pragma once
// One aircraft's position and Mach number read from the batched simulator, as the race
// systems (terminations, collisions, goals, rewards) all need them. Inline: they sit in per-step
// loops over aircraft.
#include "dynamics/engine.hpp"
#include "dynamics/f16_batch.hpp"
#include "race/track.hpp"

namespace f16race::race {

// North, east, up [ft].
inline Vec3 aircraft_position(const dynamics::F16Batch& sim, int i) {
  return {sim.state(dynamics::kPn)[i], sim.state(dynamics::kPe)[i], sim.state(dynamics::kAlt)[i]};
}

inline double aircraft_mach(const dynamics::F16Batch& sim, int i) {
  return dynamics::air_data(sim.state(dynamics::kVt)[i], sim.state(dynamics::kAlt)[i]).mach;
}

}  // namespace f16race::race
