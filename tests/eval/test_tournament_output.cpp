// done.txt, a tournament folder's last file: the study counts the tournament as done only when it
// records the same options and every figure drawn.
#include <gtest/gtest.h>

#include <filesystem>
#include <fstream>
#include <string>

#include "eval/tournament_output.hpp"
#include "support/temp_paths.hpp"

namespace f16race::eval {
namespace {

namespace fs = std::filesystem;

TournamentOptions options(const std::string& out) {
  TournamentOptions o;
  o.runs = {"study/dt8/es_s1", "study/dt8/es_d3_s1"};
  o.controls = true;
  o.races_per_pair = 32;
  o.out_dir = out;
  return o;
}

TEST(TournamentOutput, DoneOnlyWithTheSameOptionsAndEveryFigure) {
  const std::string dir = test_support::fresh_temp_path("tournament_marker");
  const TournamentOptions o = options(dir);
  std::string why;
  EXPECT_FALSE(tournament_complete(o, &why));
  EXPECT_NE(why.find("done.txt is missing"), std::string::npos) << why;

  write_tournament_marker(o, {}, dir);
  EXPECT_TRUE(tournament_complete(o, &why)) << why;
  TournamentOptions same = o;  // the same study reached through another spelling of its folder
  same.runs = {"./study/dt8/es_s1/", "/abs/study/dt8/es_d3_s1"};
  EXPECT_TRUE(tournament_complete(same, &why)) << why;

  TournamentOptions more = o;
  more.races_per_pair = 64;
  EXPECT_FALSE(tournament_complete(more, &why));
  EXPECT_EQ(why, "it was raced with other options");
  TournamentOptions fewer = o;
  fewer.runs.pop_back();
  EXPECT_FALSE(tournament_complete(fewer, &why));

  write_tournament_marker(o, {"tournament.png (gnuplot failed on x.gp: bad)"}, dir);
  EXPECT_FALSE(tournament_complete(o, &why));
  EXPECT_EQ(why, "figures: missing tournament.png (gnuplot failed on x.gp: bad)");
}

// Races on another tracks file, or on the same file edited, or against another autopilot set
// point are other races: the folder is not done for them.
TEST(TournamentOutput, TracksFileBytesAndAutopilotAirspeedArePartOfTheOptions) {
  const std::string dir = test_support::fresh_temp_path("tournament_marker_tracks");
  fs::create_directories(dir);
  const std::string tracks = dir + "/long.yaml";
  std::ofstream(tracks) << "race: {track: {n_waypoints: 15}}\n";
  TournamentOptions o = options(dir);
  o.tracks_config = tracks;
  o.autopilot_airspeed_ftps = 640.0;
  write_tournament_marker(o, {}, dir);
  std::string why;
  EXPECT_TRUE(tournament_complete(o, &why)) << why;

  TournamentOptions runs_tracks = o;
  runs_tracks.tracks_config.clear();
  EXPECT_FALSE(tournament_complete(runs_tracks, &why));
  EXPECT_EQ(why, "it was raced with other options");
  TournamentOptions slower = o;
  slower.autopilot_airspeed_ftps = 620.0;
  EXPECT_FALSE(tournament_complete(slower, &why));
  std::ofstream(tracks) << "race: {track: {n_waypoints: 14}}\n";
  EXPECT_FALSE(tournament_complete(o, &why));
  std::ofstream(tracks) << "race: {track: {n_waypoints: 15}}\n";
  EXPECT_TRUE(tournament_complete(o, &why)) << why;
  fs::remove(tracks);
  EXPECT_FALSE(tournament_complete(o, &why));
}

TEST(TournamentOutput, NamesEveryFileATournamentWritesAndNothingElse) {
  for (const char* f : {"races.csv", "pairings.csv", "summary.json", "summary.md", "variants.csv", "variant_matrix.csv",
                        "heatmap.csv", "tournament.gp", "tournament.png", "pairings.gp", "pairings.png", "done.txt"})
    EXPECT_TRUE(is_tournament_output(f)) << f;
  for (const char* f : {"races.csv.gz", "notes.md", "es_s1", "config.yaml", ""}) EXPECT_FALSE(is_tournament_output(f)) << f;
}

}  // namespace
}  // namespace f16race::eval
