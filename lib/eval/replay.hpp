#pragma once
// One race between a trained run (blue) and an opponent (red), recorded for inspection: both
// teams greedy (the HL's best bins, the LL's mean action) unless epsilon > 0.
#include <cstdint>
#include <limits>
#include <string>
#include <vector>

#include "race/block_events.hpp"
#include "race/race_config.hpp"
#include "race/race_recorder.hpp"

namespace f16race::eval {

struct ReplayOptions {
  // blue: a run folder written by `f16race train`; "RUN@center" / "RUN@random" flies the run's
  // low level under the tournament's fixed HL rules, "RUN@center_x" / "_y" / "_z" its own high
  // level with that axis on the middle bin (see eval/tournament.hpp)
  std::string run;
  // red: a run folder (with an optional @rule as for blue), "self" (default: the same spec as
  // `run`), "untrained", "scripted", "autopilot" or "autopilot@line" (its start lanes shifted onto
  // the race's racing line, as tournament --autopilot-on-line)
  std::string opponent;
  std::uint64_t seed = 1;  // track and starting positions
  double epsilon = 0.0;    // HL exploration of both teams
  // NaN: the run's race.goal_shift_up_frac; else every goal moved up by this fraction of the radius
  // (replay --set race.goal_shift_up_frac=X).
  double goal_shift_up_frac = std::numeric_limits<double>::quiet_NaN();
};

// One replayed race: its trace, who flew it and the blocks in it (dynamics::ReplayResult is the
// unrelated one-aircraft reference replay).
struct RaceReplay {
  race::RaceTrace trace;
  std::string blue, red;                 // entry names
  std::vector<race::BlockEvent> blocks;  // in the order they happened (race/block_events.hpp)
  race::RaceConfig race;                 // the race flown (n_env 1): its step, finish line and goal frame
  race::TubeLine line;                   // the racing line its goals were placed around (empty: the center-line)
};

// Throws io::InputError naming the folder when a run is missing, corrupt or was trained for
// another race shape than the blue run.
RaceReplay run_replay(const ReplayOptions& options);

// replay_agentK.csv, replay_goals.csv, replay_track.csv, replay_tube.csv, replay_blocks.csv, replay.png (+ .gp),
// replay.acmi and replay.md (who won, how, each aircraft's fate) into out_dir. Returns false
// with `message` when gnuplot is missing (everything else is still written).
bool write_replay(const RaceReplay& result, const std::string& out_dir, std::string* message);

// Whether `name` is one of the files write_replay writes (replay.*, replay_*): the only ones
// `replay --out` may replace.
bool is_replay_output(const std::string& name);

}  // namespace f16race::eval
