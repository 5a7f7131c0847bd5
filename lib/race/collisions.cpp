#include "race/collisions.hpp"

#include "race/aircraft_state.hpp"
#include "race/race_env.hpp"

namespace f16race::race {

void find_collisions(const RaceConfig& c, const dynamics::F16Batch& sim, int base, int n_agent,
                     const std::uint8_t* acted, std::int8_t* cause) {
  for (int a = 0; a < n_agent; ++a) {
    if (!acted[a]) continue;
    for (int b = a + 1; b < n_agent; ++b) {
      if (!acted[b]) continue;
      const Vec3 d = aircraft_position(sim, base + a) - aircraft_position(sim, base + b);
      if (dot(d, d) < c.collision_radius_ft * c.collision_radius_ft) {
        const bool teammates = RaceEnv::team_of(a, c.team_size) == RaceEnv::team_of(b, c.team_size);
        const std::int8_t hit = teammates ? kCauseTeamCollision : kCauseCollision;
        for (const int k : {a, b})
          if (cause[k] == kCauseNone || (cause[k] == kCauseCollision && hit == kCauseTeamCollision))
            cause[k] = hit;
      }
    }
  }
}

}  // namespace f16race::race
