#pragma once
// A tournament's races, flown in one batch of envs: the games (who flies which side of which
// track), and the loop that races them, each env taking the next game as its race ends.
#include <functional>
#include <vector>

#include "eval/tournament.hpp"
#include "race/race_env.hpp"

namespace f16race::dist {
class Group;
}
namespace f16race::train {
struct RunPolicy;
}

namespace f16race::eval {

class TournamentJournal;

struct Game {
  int pair, blue, red;
  int race;  // index in its pairing: track race / 2, sides swapped on odd races
};

struct RaceGamesInputs {
  const TournamentOptions* options = nullptr;
  const std::vector<Entry>* entries = nullptr;
  std::vector<train::RunPolicy>* policies = nullptr;  // what the entries fly (Entry::policy)
  race::RaceConfig race;                              // its n_env is replaced by this rank's envs
  const std::vector<Game>* games = nullptr;           // the games to race, in order of assignment
  long done_before = 0;  // races of `total` raced before (progress counts them)
  long total = 0;
  std::function<void(long, long)> progress;  // (done, total), about every 1 % of the games
  dist::Group* group = nullptr;              // ranks split the batch's envs; nullptr: one process
  const TournamentJournal* journal = nullptr;  // each race appended in the step it ended, if any
};

// Races `games` and returns this rank's records, in the order the races ended.
std::vector<RaceRecord> race_games(const RaceGamesInputs& in);

}  // namespace f16race::eval
