#pragma once
// The race with every goal around the center-line and no height shifts: the paper's goal geometry,
// which the goal-placement tests measure against. The default race (goals around the racing line,
// 0.3 R lower) is this plus race.goal_line_frac and the shifts, each with tests of its own.
#include "race/race_config.hpp"

namespace f16race::test_support {

inline race::RaceConfig center_line_race() {
  race::RaceConfig c;
  c.goal_line_frac = 0.0;
  c.goal_shift_up_frac = 0.0;
  c.autopilot_shift_up_frac = 0.0;
  return c;
}

}  // namespace f16race::test_support
