// The tournament journal: a tournament stopped part way and run again keeps the races it had and
// ends with the same races, and the same races.csv bytes, as one unbroken run; a journal of
// another tournament, or with a line that is not one of its races, is started anew.
#include <gtest/gtest.h>
#include <yaml-cpp/yaml.h>

#include <filesystem>
#include <fstream>
#include <iterator>
#include <string>
#include <vector>

#include "eval/tournament.hpp"
#include "eval/tournament_journal.hpp"
#include "eval/tournament_report.hpp"
#include "io/atomic_file.hpp"
#include "io/input_error.hpp"
#include "io/yaml_config.hpp"
#include "train/trainer.hpp"

namespace f16race::eval {
namespace {

namespace fs = std::filesystem;

std::string journal_trained_run(const std::string& name, int seed) {
  const fs::path dir = fs::temp_directory_path() / ("f16race_journal_" + name);
  fs::remove_all(dir);
  YAML::Node root = YAML::Load(R"(
config_version: 1  # the tiny runs these tests were written for: version 1's defaults
race: {n_env: 2, team_size: 2, time_limit_s: 10.0, dt_hl_s: 1.6, track: {n_waypoints: 5}}
ll: {n_steps: 8, n_minibatches: 2, n_epochs: 1, hidden: [8, 8], d_model: 8, n_heads: 2}
hl: {hidden: [8, 8], d_model: 8, n_heads: 2, n_atoms: 11, n_steps_per_update: 1}
train: {total_env_steps: 100, ll_phase_updates: 1, hl_phase_updates: 1}
)");
  io::apply_override(root, "seed=" + std::to_string(seed));
  train::Trainer t(train::read_train_config(root, "test"), dir.string());
  t.run(nullptr, 2);
  return dir.string();
}

std::vector<std::string> journal_lines(const std::string& path) {
  std::ifstream in(path);
  std::vector<std::string> out;
  for (std::string l; std::getline(in, l);) out.push_back(l);
  return out;
}

std::string journal_races_csv(const TournamentResult& r, const std::string& name) {
  const std::string path = (fs::temp_directory_path() / name).string();
  write_races_csv(r, path);
  return io::read_file(path);
}

TEST(TournamentJournal, LinesComeBackExactly) {
  RaceRecord r;
  r.pair = 7;
  r.race = 13;
  r.blue = 3;
  r.red = 1;
  r.track = 6;
  r.env = 250;
  r.winner = 1;
  r.end_reason = 2;
  r.duration_s = 28.400000000000002;  // not 28.4: the last bit must survive
  r.blue_blocks = 4;
  r.red_blocks = 0;
  r.blue_lost[1] = 2;
  r.red_lost[race::kNumCauses - 1] = 1;
  r.blue_choices[0] = 5;
  r.red_choices[kChoiceFields - 1] = 9;
  RaceRecord back;
  ASSERT_TRUE(parse_journal_line(journal_line(r), &back));
  EXPECT_EQ(back.pair, 7);
  EXPECT_EQ(back.race, 13);
  EXPECT_EQ(back.blue, 3);
  EXPECT_EQ(back.red, 1);
  EXPECT_EQ(back.track, 6);
  EXPECT_EQ(back.env, 250);
  EXPECT_EQ(back.winner, 1);
  EXPECT_EQ(back.end_reason, 2);
  EXPECT_EQ(back.duration_s, r.duration_s);
  EXPECT_NE(back.duration_s, 28.4);
  EXPECT_EQ(back.blue_blocks, 4);
  EXPECT_EQ(back.blue_lost, r.blue_lost);
  EXPECT_EQ(back.red_lost, r.red_lost);
  EXPECT_EQ(back.blue_choices, r.blue_choices);
  EXPECT_EQ(back.red_choices, r.red_choices);
  const std::string line = journal_line(r);
  EXPECT_FALSE(parse_journal_line(line.substr(0, line.size() - 2), &back)) << "a line cut short";
  EXPECT_FALSE(parse_journal_line(line + " 5", &back)) << "a field too many";
  EXPECT_FALSE(parse_journal_line("", &back));
  EXPECT_EQ(tournament_journal_path("runs/t"), "runs/.t.journal");
  EXPECT_EQ(tournament_journal_path("runs/t/"), "runs/.t.journal");
}

// One writer at a time: a second tournament on the same --out is refused with one line, not
// left to interleave its races with the first's.
TEST(TournamentJournal, SecondWriterIsRefused) {
  const std::string path = (fs::temp_directory_path() / "f16race_journal_locked.journal").string();
  fs::remove(path);
  auto any = [](const RaceRecord&) { return true; };
  {
    TournamentJournal first(path, "one", any);
    try {
      TournamentJournal second(path, "one", any);
      FAIL() << "a second writer was let in";
    } catch (const io::InputError& e) {
      EXPECT_NE(std::string(e.what()).find("held by another f16race tournament"), std::string::npos) << e.what();
      EXPECT_NE(std::string(e.what()).find(path), std::string::npos) << e.what();
    }
    RaceRecord r;
    first.append({r});
  }
  const TournamentJournal after(path, "one", any);  // the lock went with the first
  EXPECT_EQ(after.kept().size(), 1u);
}

// Stop after k races (the journal cut to k lines and half a line, as a kill leaves it), run
// again: k races kept, the rest raced, the whole the same as the unbroken tournament.
TEST(TournamentJournal, StoppedTournamentEndsAsTheUnbrokenOne) {
  TournamentOptions o;
  o.runs = {journal_trained_run("a", 1), journal_trained_run("b", 2)};
  o.include_untrained = true;
  o.controls = true;
  o.races_per_pair = 6;
  o.batch_envs = 5;  // fewer than the games: envs take new games as races end
  o.bootstrap_replicates = 200;
  const TournamentResult unbroken = run_tournament(o);
  const long total = static_cast<long>(unbroken.races.size());
  ASSERT_EQ(total, 21 * 6) << "7 entries (2 runs, untrained, 2 controls each), 21 pairings";

  o.journal_path = (fs::temp_directory_path() / "f16race_journal_t.journal").string();
  fs::remove(o.journal_path);
  std::string note = "none";
  const TournamentResult journaled = run_tournament(o, {}, nullptr, [&](const std::string& l) { note = l; });
  EXPECT_EQ(note, "none") << "no journal yet: nothing to say";
  const std::vector<std::string> lines = journal_lines(o.journal_path);
  ASSERT_EQ(static_cast<long>(lines.size()), 2 + total) << "a header, an identity, a line per race";

  const int k = 37;
  {
    std::ofstream cut(o.journal_path, std::ios::trunc);
    for (int i = 0; i < 2 + k; ++i) cut << lines[i] << "\n";
    cut << lines[2 + k].substr(0, lines[2 + k].size() / 2);
  }
  long first_done = -1;
  const TournamentResult resumed = run_tournament(
      o, [&](long done, long) { if (first_done < 0) first_done = done; }, nullptr,
      [&](const std::string& l) { note = l; });
  EXPECT_NE(note.find("resuming: 37 races kept from"), std::string::npos) << note;
  EXPECT_NE(note.find("cut short"), std::string::npos) << note;
  EXPECT_GT(first_done, k) << "progress counts the kept races";
  EXPECT_EQ(static_cast<long>(journal_lines(o.journal_path).size()), 2 + total) << "the cut line dropped, the rest appended";
  const std::string want = journal_races_csv(unbroken, "f16race_journal_unbroken.csv");
  EXPECT_EQ(journal_races_csv(journaled, "f16race_journal_journaled.csv"), want);
  EXPECT_EQ(journal_races_csv(resumed, "f16race_journal_resumed.csv"), want);
  EXPECT_EQ(resumed.wins, unbroken.wins);
  EXPECT_EQ(resumed.games, unbroken.games);

  // A whole journal: nothing left to race, the same tournament again.
  const TournamentResult again = run_tournament(o, {}, nullptr, [&](const std::string& l) { note = l; });
  EXPECT_NE(note.find("resuming: 126 races kept"), std::string::npos) << note;
  EXPECT_EQ(journal_races_csv(again, "f16race_journal_again.csv"), want);
}

// Another tournament's journal (other races per pair), or one with a line that is not a race of
// this tournament, is started anew, and the tournament is raced whole.
TEST(TournamentJournal, OtherTournamentsJournalStartsAnew) {
  TournamentOptions o;
  o.runs = {journal_trained_run("c", 3)};
  o.include_untrained = true;
  o.races_per_pair = 4;
  o.bootstrap_replicates = 200;
  o.journal_path = (fs::temp_directory_path() / "f16race_journal_other.journal").string();
  fs::remove(o.journal_path);
  TournamentOptions four = o;
  const TournamentResult r4 = run_tournament(four);
  std::vector<std::string> lines = journal_lines(o.journal_path);
  ASSERT_EQ(lines.size(), 2u + 4u);

  TournamentOptions six = o;
  six.races_per_pair = 6;
  std::string note;
  const TournamentResult r6 = run_tournament(six, {}, nullptr, [&](const std::string& l) { note = l; });
  EXPECT_NE(note.find("written for another tournament"), std::string::npos) << note;
  EXPECT_EQ(r6.races.size(), 6u);
  EXPECT_EQ(journal_lines(o.journal_path).size(), 2u + 6u);

  // Back to four races with a forged line: a race of pairing 0 between other entries.
  fs::remove(o.journal_path);
  run_tournament(four);
  lines = journal_lines(o.journal_path);
  RaceRecord forged;
  ASSERT_TRUE(parse_journal_line(lines[3], &forged));
  std::swap(forged.blue, forged.red);
  {
    std::ofstream f(o.journal_path, std::ios::trunc);
    f << lines[0] << "\n" << lines[1] << "\n" << lines[2] << "\n" << journal_line(forged) << "\n";
  }
  const TournamentResult fixed = run_tournament(four, {}, nullptr, [&](const std::string& l) { note = l; });
  EXPECT_NE(note.find("line 4 is not a race of this tournament"), std::string::npos) << note;
  EXPECT_EQ(journal_races_csv(fixed, "f16race_journal_fixed.csv"), journal_races_csv(r4, "f16race_journal_r4.csv"));
}

}  // namespace
}  // namespace f16race::eval
