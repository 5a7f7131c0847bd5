// Temporaries of killed writers are removed by the next owner of the folder; a live writer's,
// any other name, and anything below the folder are left alone.
#include <gtest/gtest.h>
#include <sys/wait.h>
#include <unistd.h>

#include <filesystem>
#include <set>
#include <string>

#include "io/atomic_file.hpp"
#include "io/stale_temporaries.hpp"
#include "support/temp_paths.hpp"

namespace f16race::io {
namespace {

namespace fs = std::filesystem;

pid_t dead_pid() {
  const pid_t pid = fork();
  if (pid == 0) _exit(0);
  waitpid(pid, nullptr, 0);
  return pid;
}

std::set<std::string> names_in(const std::string& dir) {
  std::set<std::string> out;
  for (const auto& e : fs::directory_iterator(dir)) out.insert(e.path().filename().string());
  return out;
}

TEST(StaleTemporaries, ReadsTheWritersPidFromEachKindOfTemporary) {
  EXPECT_EQ(temporary_owner_pid("summary.json.tmp.4242"), 4242);      // write_file_atomic
  EXPECT_EQ(temporary_owner_pid(".tournament.png.tmp.77.3"), 77);     // render_plot
  EXPECT_EQ(temporary_owner_pid(".export.tmp.123"), 123);             // StagedFolder
  EXPECT_EQ(temporary_owner_pid(".export.old.tmp.123"), 123);         // its fallback swap
  EXPECT_EQ(temporary_owner_pid("notes.txt"), 0);
  EXPECT_EQ(temporary_owner_pid("data.tmp.csv"), 0);
  EXPECT_EQ(temporary_owner_pid("a.tmp.12.b"), 0);
  EXPECT_EQ(temporary_owner_pid("a.tmp."), 0);
  EXPECT_EQ(temporary_owner_pid("a.tmp.99999999999"), 0);  // longer than any pid
}

TEST(StaleTemporaries, TellsLiveProcessesFromGoneOnes) {
  EXPECT_TRUE(process_alive(getpid()));
  EXPECT_TRUE(process_alive(1));  // init: alive, even where it may not be signalled
  EXPECT_FALSE(process_alive(dead_pid()));
  const pid_t zombie = fork();
  if (zombie == 0) _exit(0);
  for (int i = 0; i < 200 && process_alive(zombie); ++i) usleep(10000);  // exits, not yet reaped
  EXPECT_FALSE(process_alive(zombie));
  waitpid(zombie, nullptr, 0);
}

TEST(StaleTemporaries, RemovesOnlyDeadWritersTemporariesInTheFolderItself) {
  const std::string dir = test_support::fresh_temp_path("stale_temporaries");
  const std::string dead = std::to_string(dead_pid()), live = std::to_string(getpid());
  for (const std::string& f : std::vector<std::string>{"summary.json.tmp." + dead, ".curves.png.tmp." + dead + ".2",
                                                       "races.csv.tmp." + live, "summary.json", "notes.tmp.txt",
                                                       "sub/x.csv.tmp." + dead})
    write_file_atomic(dir + "/" + f, "x");
  write_file_atomic(dir + "/.tournament.tmp." + dead + "/races.csv", "staged");  // a staging folder
  const std::vector<std::string> removed = remove_stale_temporaries(dir);
  EXPECT_EQ(removed, (std::vector<std::string>{".curves.png.tmp." + dead + ".2", ".tournament.tmp." + dead,
                                               "summary.json.tmp." + dead}));
  EXPECT_EQ(names_in(dir), (std::set<std::string>{"races.csv.tmp." + live, "summary.json", "notes.tmp.txt", "sub"}));
  EXPECT_TRUE(fs::exists(dir + "/sub/x.csv.tmp." + dead));  // below the folder: not this call's
}

TEST(StaleTemporaries, APrefixLimitsWhatIsLookedAt) {
  const std::string dir = test_support::fresh_temp_path("stale_prefix");
  const std::string dead = std::to_string(dead_pid());
  for (const std::string& f : {".out.tmp." + dead, ".other.tmp." + dead}) write_file_atomic(dir + "/" + f, "x");
  EXPECT_EQ(remove_stale_temporaries(dir, ".out."), std::vector<std::string>{".out.tmp." + dead});
  EXPECT_EQ(names_in(dir), std::set<std::string>{".other.tmp." + dead});
}

TEST(StaleTemporaries, AMissingFolderIsNotAnError) {
  EXPECT_TRUE(remove_stale_temporaries("/nonexistent/f16race").empty());
}

}  // namespace
}  // namespace f16race::io
