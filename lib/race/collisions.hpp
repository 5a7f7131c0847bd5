#pragma once
// Mid-air collisions within one env's step: any two aircraft that flew it and end it closer than
// race.collision_radius_ft are both out.
#include <cstdint>

#include "dynamics/f16_batch.hpp"
#include "race/race_config.hpp"
#include "race/terminations.hpp"

namespace f16race::race {

// Over the env's aircraft [base, base + n_agent) that acted this step (acted: the env's slice):
// a collision sets cause[a] of both aircraft to kCauseTeamCollision (teammates) or
// kCauseCollision (opponents) unless a's step already has another cause; a teammate's
// collision outranks an opponent's.
void find_collisions(const RaceConfig& c, const dynamics::F16Batch& sim, int base, int n_agent,
                     const std::uint8_t* acted, std::int8_t* cause);

}  // namespace f16race::race
