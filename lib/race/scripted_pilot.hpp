#pragma once
// A hand-written pilot for the race: keep the lane you started in and fly toward the tube's
// center-line a few seconds ahead. It proves tracks are flyable, gives `f16race race` something
// to show without a trained policy, and is a baseline opponent.
#include <cstdint>

#include <vector>

#include "race/race_env.hpp"
#include "race/track_line.hpp"

namespace f16race::race {

struct ScriptedPilotConfig {
  double lookahead_ft = 2500.0;    // aim point this far ahead along the center-line
  double lane_fraction = 0.8;      // keep this fraction of the start offset (lane keeping)
  double speed_ftps = 700.0;       // speed hold target
  double k_heading = 5.0;          // bank angle per rad of heading error
  double max_bank_rad = 1.2;
  double k_bank = 3.0;             // roll-rate ref per rad of bank error [1/s]
  double k_climb = 1.5;            // extra g per (rad of flight-path error * vt / g)
  double k_speed = 0.004;          // throttle per ft/s of speed error
};

// Writes LL actions [n_env, n_agent, 3] in [-1, 1] for the aircraft in `rows` (indices into
// env * n_agent + agent, n_rows of them), or for every aircraft of `env` when rows is null; the
// other aircraft's actions are left as they are.
void scripted_actions(const RaceEnv& env, const ScriptedPilotConfig& pilot, float* actions,
                      const std::int64_t* rows = nullptr, std::int64_t n_rows = 0);

// The classic-control baseline: AeroBench's waypoint autopilot (dynamics/waypoint_autopilot.hpp,
// its gains and limits unchanged) chasing a waypoint on the track, lookahead_ft ahead in the
// aircraft's start lane (the scripted pilot's kind of aim point, farther ahead, so four aircraft of a team do
// not converge on one line), its airspeed set point the race's start speed. Its references are
// mapped to the race's action ranges (ps and Nz clipped to them where AeroBench's exceed them).
struct AutopilotPilotConfig {
  // Like the spacing of AeroBench's example waypoints (5 000-10 000 ft), which its gentle gains
  // are tuned for. Measured on 8 races (tests/race): 6 000 ft brings all 8 to the finish line
  // with 63 of 64 aircraft; 2 500 ft (the scripted pilot's) 3 races and 31 aircraft, the gains
  // too slow for an aim point that close; on the center-line itself (lane_fraction 0) teammates
  // converge and collide (18 of 64 left).
  double lookahead_ft = 6000.0;
  double lane_fraction = 0.8;
  double airspeed_ftps = 700.0;
  // Whose lane: the start lane (the non-learned `autopilot` entry), or the lane of the aircraft's
  // HL goal, at the same fraction of the tube radius at the aim point as at the goal (a low
  // level that flies exactly what the high level asks: train.ll_pilot autopilot).
  bool follow_goal = false;
  // Non-null (start lanes only): each env's racing line, [n_env], its offsets added to the lane:
  // the team flies its lanes shifted onto the line.
  const std::vector<TubeLine>* lines = nullptr;
  // On a line or shifted, the aim point's offset from the center-line is held within this fraction
  // of the local radius: a lane near the wall plus a cut or a shift would aim outside the tube
  // (0.8; 1: not held). Start lanes alone are never held.
  double line_max_offset_frac = 0.8;
  // Start lanes only: the aim point moved up by this fraction of the local radius (negative: down),
  // then held within line_max_offset_frac. Under a Mach governor lower air is faster.
  double shift_up_frac = 0.0;
};
// As scripted_actions: the aircraft in `rows`, or all of them.
void autopilot_actions(const RaceEnv& env, const AutopilotPilotConfig& pilot, float* actions,
                       const std::int64_t* rows = nullptr, std::int64_t n_rows = 0);

}  // namespace f16race::race
