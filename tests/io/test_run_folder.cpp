// Run folders: one writer at a time (flock), what counts as a run, moving a run aside intact.
#include <gtest/gtest.h>
#include <unistd.h>

#include <filesystem>
#include <fstream>
#include <iterator>
#include <stdexcept>
#include <string>

#include "io/run_folder.hpp"
#include "support/temp_paths.hpp"

namespace f16race::io {
namespace {

namespace fs = std::filesystem;

std::string fresh_dir(const std::string& name) { return test_support::fresh_temp_path("run_folder_" + name); }

TEST(RunFolderLock, SecondWriterIsRefusedWithTheHoldersPidUntilTheFirstEnds) {
  const std::string dir = fresh_dir("lock");
  {
    RunFolderLock first(dir);
    EXPECT_TRUE(fs::is_directory(dir));
    try {
      RunFolderLock second(dir);
      FAIL() << "a second lock on one run folder was granted";
    } catch (const std::runtime_error& e) {
      const std::string m = e.what();
      EXPECT_NE(m.find(dir + " is in use"), std::string::npos) << m;
      EXPECT_NE(m.find("pid " + std::to_string(getpid())), std::string::npos) << m;
      EXPECT_EQ(m.find('\n'), std::string::npos) << m;
    }
    RunFolderLock moved(std::move(first));  // the lock travels with the object
    EXPECT_THROW(RunFolderLock third(dir), std::runtime_error);
  }
  EXPECT_NO_THROW(RunFolderLock again(dir));  // released with its owner
}

std::string lock_text(const std::string& dir) {
  std::ifstream in(dir + "/.lock", std::ios::binary);
  return std::string(std::istreambuf_iterator<char>(in), std::istreambuf_iterator<char>());
}

// A process that takes the lock and then refuses the folder leaves the file as it found it; one
// that claims it (it writes the run) leaves its pid, which names the writer of that run.
TEST(RunFolderLock, AnUnclaimedLockLeavesTheFileAsFoundAClaimedOneItsPid) {
  const std::string dir = fresh_dir("claim");
  fs::create_directories(dir);
  { std::ofstream(dir + "/.lock") << "4242\n"; }
  {
    RunFolderLock refused(dir);
    EXPECT_EQ(lock_text(dir), std::to_string(getpid()) + "\n");  // the holder, while held
  }
  EXPECT_EQ(lock_text(dir), "4242\n");
  {
    RunFolderLock writer(dir);
    writer.claim();
    RunFolderLock moved(std::move(writer));  // the claim travels with the lock
  }
  EXPECT_EQ(lock_text(dir), std::to_string(getpid()) + "\n");
  const std::string fresh = fresh_dir("claim_new");
  { RunFolderLock refused(fresh); }
  EXPECT_TRUE(fs::exists(fresh + "/.lock"));  // kept, empty: unlinking could split the lock
  EXPECT_EQ(lock_text(fresh), "");
}

TEST(RunFolder, RunDataIsAnythingButTheLockAndEmptyFolders) {
  const std::string dir = fresh_dir("data");
  EXPECT_TRUE(run_data_in(dir).empty());  // missing folder
  fs::create_directories(fs::path(dir) / "checkpoint");
  fs::create_directories(fs::path(dir) / "pool");
  { RunFolderLock lock(dir); }
  EXPECT_TRUE(run_data_in(dir).empty());
  std::ofstream(fs::path(dir) / "metrics.csv") << "update\n";
  fs::create_directories(fs::path(dir) / "checkpoint" / "step_0000000100");
  EXPECT_EQ(run_data_in(dir), (std::vector<std::string>{"checkpoint", "metrics.csv"}));
}

TEST(RunFolder, MovingAsideKeepsEveryFileAndPicksAFreeName) {
  const std::string dir = fresh_dir("aside");
  fs::create_directories(dir);
  std::ofstream(fs::path(dir) / "config.yaml") << "seed: 1\n";
  EXPECT_EQ(move_run_aside(dir), dir + ".old-1");
  EXPECT_FALSE(fs::exists(dir));
  fs::create_directories(dir);
  std::ofstream(fs::path(dir) / "config.yaml") << "seed: 2\n";
  EXPECT_EQ(move_run_aside(dir + "/"), dir + ".old-2");
  std::ifstream a(dir + ".old-1/config.yaml"), b(dir + ".old-2/config.yaml");
  std::string la, lb;
  std::getline(a, la);
  std::getline(b, lb);
  EXPECT_EQ(la, "seed: 1");
  EXPECT_EQ(lb, "seed: 2");
  EXPECT_THROW(move_run_aside(dir), std::runtime_error);  // nothing there any more
}

}  // namespace
}  // namespace f16race::io
