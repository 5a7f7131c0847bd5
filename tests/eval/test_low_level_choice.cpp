// The races that choose a run's low level (train.ll_choice_snapshots) are the tournament's: a low
// level's winrate against the autopilot equals RUN@center's against `autopilot` in a tournament
// with --controls --with-autopilot on the same seed, race for race.
#include <gtest/gtest.h>

#include <string>

#include "eval/low_level_choice.hpp"
#include "eval/tournament.hpp"
#include "train/run_policy.hpp"
#include "train/trainer.hpp"

namespace f16race::eval {
namespace {

const std::string kTeam = F16RACE_EXAMPLES_DIR "/trained_team";

TEST(LowLevelChoice, WinratesAreTheTournamentsCenterControlAgainstTheAutopilot) {
  TournamentOptions o;
  o.runs = {kTeam};
  o.include_untrained = false;
  o.include_autopilot = true;
  o.controls = true;
  o.races_per_pair = 16;
  o.seed = 5;
  const TournamentResult t = run_tournament(o);
  ASSERT_EQ(t.entries[1].name, "autopilot");
  ASSERT_EQ(t.entries[2].name, "trained_team@center");
  const train::RunPolicy team = train::load_run_policy(kTeam);
  LowLevelChoiceInputs in;
  in.config = &team.config;
  in.ll_files = {team.checkpoint_dir + "/ll.pt"};
  in.races = 16;
  in.tracks_seed = 5;
  const std::vector<double> w = center_vs_autopilot_winrates(in);
  ASSERT_EQ(w.size(), 1u);
  EXPECT_EQ(w[0], t.wins[2][1] / t.games[2][1]);
  EXPECT_GT(w[0], 0.0);  // the shipped pilot wins some races: a real comparison, not 0 == 0
  EXPECT_LT(w[0], 1.0);
  in.tracks_seed = low_level_choice_tracks_seed(1);
  EXPECT_NE(in.tracks_seed, 1u);  // never the tracks of a default tournament
}

}  // namespace
}  // namespace f16race::eval
