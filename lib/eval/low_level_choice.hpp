#pragma once
// The races that choose the low level of a run with train.ll_choice_snapshots (train's
// LowLevelRater): each candidate low level under a center-line high level (the `@center`
// control) against AeroBench's autopilot, the tournament's races on tracks of their own.
#include <cstdint>
#include <string>
#include <vector>

#include "train/train_config.hpp"

namespace f16race::eval {

struct LowLevelChoiceInputs {
  const train::TrainConfig* config = nullptr;  // the run's: its race, networks and autopilot
  std::vector<std::string> ll_files;           // the candidates' ll.pt
  int races = 384;                             // per candidate, half on each side
  std::uint64_t tracks_seed = 0;               // a tournament's --seed
};

// The tracks the choice of run seed `seed` races on: a tournament seed no evaluation uses by
// default (those use 1), so the runs' kept tournaments judge the choice on other tracks.
std::uint64_t low_level_choice_tracks_seed(std::uint64_t seed);

// Each candidate's winrate (draws count half) against the autopilot, in ll_files order; the same
// races, bit for bit, as `tournament --controls --with-autopilot --seed S` gives RUN@center
// against the autopilot for a run flying that low level.
std::vector<double> center_vs_autopilot_winrates(const LowLevelChoiceInputs& in);

}  // namespace f16race::eval
