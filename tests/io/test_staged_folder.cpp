// A staged output folder appears whole or not at all: a commit replaces every file of the earlier
// output at once, a failed write leaves the earlier output as it was and no staging folder, and a
// folder holding anything but the command's outputs is refused untouched.
#include <gtest/gtest.h>
#include <sys/resource.h>
#include <sys/wait.h>
#include <unistd.h>

#include <csignal>
#include <filesystem>
#include <fstream>
#include <set>
#include <sstream>
#include <string>

#include "io/atomic_file.hpp"
#include "io/input_error.hpp"
#include "io/staged_folder.hpp"
#include "support/temp_paths.hpp"

namespace f16race::io {
namespace {

namespace fs = std::filesystem;

bool owned(const std::string& name) { return name == "a.txt" || name == "b.txt" || name == "c.txt"; }

std::string read_all(const std::string& path) {
  std::ifstream f(path, std::ios::binary);
  std::stringstream ss;
  ss << f.rdbuf();
  return ss.str();
}

std::set<std::string> names_in(const std::string& dir) {
  std::set<std::string> out;
  for (const auto& e : fs::directory_iterator(dir)) out.insert(e.path().filename().string());
  return out;
}

// A parent folder holding one output folder, `out`, with a.txt and b.txt of version "old".
std::string earlier_output(const std::string& name) {
  const std::string parent = test_support::fresh_temp_path("staged_" + name);
  fs::create_directories(parent + "/out");
  write_file_atomic(parent + "/out/a.txt", "old a");
  write_file_atomic(parent + "/out/b.txt", "old b");
  return parent;
}

// A pid that no process has: a child that has exited and been reaped.
pid_t dead_pid() {
  const pid_t pid = fork();
  if (pid == 0) _exit(0);
  waitpid(pid, nullptr, 0);
  return pid;
}

TEST(StagedFolder, CommitReplacesTheWholeEarlierOutput) {
  const std::string parent = earlier_output("commit");
  StagedFolder folder(parent + "/out", "test", owned);
  EXPECT_EQ(fs::path(folder.staging()).parent_path(), fs::path(parent));
  EXPECT_EQ(read_all(parent + "/out/a.txt"), "old a");  // nothing visible before the commit
  folder.commit([](const std::string& dir) {
    write_file_atomic(dir + "/a.txt", "new a");
    write_file_atomic(dir + "/c.txt", "new c");
  });
  EXPECT_EQ(names_in(parent + "/out"), (std::set<std::string>{"a.txt", "c.txt"}));  // b.txt was the old output's
  EXPECT_EQ(read_all(parent + "/out/a.txt"), "new a");
  EXPECT_EQ(names_in(parent), std::set<std::string>{"out"});  // no staging or old folder left beside it
}

TEST(StagedFolder, CommitCreatesAMissingFolderAndItsParents) {
  const std::string parent = test_support::fresh_temp_path("staged_fresh");
  StagedFolder folder(parent + "/x/y/out/", "test", owned);  // a trailing slash names the same folder
  folder.commit([](const std::string& dir) { write_file_atomic(dir + "/a.txt", "a"); });
  EXPECT_EQ(read_all(parent + "/x/y/out/a.txt"), "a");
  EXPECT_EQ(names_in(parent + "/x/y"), std::set<std::string>{"out"});
}

// Lowers the file-size limit for the scope: writes past it fail with EFBIG like a full disk.
class FileSizeLimit {
 public:
  explicit FileSizeLimit(rlim_t bytes) {
    getrlimit(RLIMIT_FSIZE, &old_);
    old_handler_ = std::signal(SIGXFSZ, SIG_IGN);
    rlimit r = old_;
    r.rlim_cur = bytes;
    setrlimit(RLIMIT_FSIZE, &r);
  }
  ~FileSizeLimit() {
    setrlimit(RLIMIT_FSIZE, &old_);
    std::signal(SIGXFSZ, old_handler_);
  }

 private:
  rlimit old_{};
  void (*old_handler_)(int) = nullptr;
};

TEST(StagedFolder, AFailedWriteLeavesTheEarlierOutputAndSaysSoInOneLine) {
  const std::string parent = earlier_output("full");
  const std::string out = parent + "/out";
  try {
    StagedFolder folder(out, "test", owned);
    FileSizeLimit limit(64);
    folder.commit([](const std::string& dir) {
      write_file_atomic(dir + "/a.txt", "new a");          // fits
      write_file_atomic(dir + "/b.txt", std::string(4096, 'x'));  // does not
    });
    FAIL() << "a write past the file-size limit was committed";
  } catch (const FileWriteError& e) {
    const std::string m = e.what();
    EXPECT_EQ(m.rfind(out + "/b.txt: ", 0), 0u) << m;  // the final folder's name, not the staging one
    EXPECT_NE(m.find("while writing; " + out + " is unchanged, none of this test output was kept"), std::string::npos) << m;
    EXPECT_EQ(m.find("nothing else was changed"), std::string::npos) << m;
    EXPECT_EQ(m.find('\n'), std::string::npos) << m;
  }
  EXPECT_EQ(read_all(out + "/a.txt"), "old a");
  EXPECT_EQ(read_all(out + "/b.txt"), "old b");
  EXPECT_EQ(names_in(parent), std::set<std::string>{"out"});  // the staging folder is gone
}

TEST(StagedFolder, AnUncommittedFolderLeavesNothing) {
  const std::string parent = earlier_output("abandoned");
  {
    StagedFolder folder(parent + "/out", "test", owned);
    write_file_atomic(folder.staging() + "/a.txt", "half");
  }
  EXPECT_EQ(read_all(parent + "/out/a.txt"), "old a");
  EXPECT_EQ(names_in(parent), std::set<std::string>{"out"});
}

TEST(StagedFolder, RefusesAFolderWithOtherFilesAndLeavesItAlone) {
  const std::string parent = earlier_output("foreign");
  write_file_atomic(parent + "/out/notes.md", "mine");
  fs::create_directories(parent + "/out/data");
  try {
    StagedFolder folder(parent + "/out", "test", owned);
    FAIL() << "a folder with other files was taken";
  } catch (const InputError& e) {
    const std::string m = e.what();
    EXPECT_EQ(m.rfind(parent + "/out: holds data/, notes.md, not test output", 0), 0u) << m;
    EXPECT_NE(m.find("move them out or choose another output folder"), std::string::npos) << m;
  }
  EXPECT_EQ(names_in(parent + "/out"), (std::set<std::string>{"a.txt", "b.txt", "data", "notes.md"}));
  EXPECT_EQ(names_in(parent), std::set<std::string>{"out"});
}

TEST(StagedFolder, RefusesAFilePutInTheFolderBeforeTheCommit) {
  const std::string parent = earlier_output("late_foreign");
  StagedFolder folder(parent + "/out", "test", owned);
  write_file_atomic(parent + "/out/late.txt", "put there meanwhile");
  EXPECT_THROW(folder.commit([](const std::string& dir) { write_file_atomic(dir + "/a.txt", "new"); }), InputError);
  EXPECT_EQ(read_all(parent + "/out/late.txt"), "put there meanwhile");
  EXPECT_EQ(read_all(parent + "/out/a.txt"), "old a");
}

TEST(StagedFolder, RefusesAFileWhereTheFolderShouldBe) {
  const std::string parent = test_support::fresh_temp_path("staged_file");
  write_file_atomic(parent + "/out", "a file");
  EXPECT_THROW(StagedFolder(parent + "/out", "test", owned), InputError);
  EXPECT_EQ(read_all(parent + "/out"), "a file");
}

TEST(StagedFolder, RemovesStaleStagingOfDeadProcessesOnly) {
  const std::string parent = earlier_output("stale");
  const std::string dead = parent + "/.out.tmp." + std::to_string(dead_pid());
  const std::string live = parent + "/.out.tmp." + std::to_string(getppid());  // the test runner's parent lives
  const std::string other = parent + "/.other.tmp." + std::to_string(dead_pid());  // another folder's
  for (const std::string& d : {dead, live, other}) write_file_atomic(d + "/a.txt", "left");
  write_file_atomic(parent + "/out/a.txt.tmp." + std::to_string(dead_pid()), "old writer's");  // not foreign
  StagedFolder folder(parent + "/out", "test", owned);
  EXPECT_FALSE(fs::exists(dead));
  EXPECT_TRUE(fs::exists(live));
  EXPECT_TRUE(fs::exists(other));  // only the folder being written is cleaned
  folder.commit([](const std::string& dir) { write_file_atomic(dir + "/a.txt", "new a"); });
  EXPECT_EQ(names_in(parent + "/out"), std::set<std::string>{"a.txt"});
}

TEST(StagedFolder, ALinkToAFolderKeepsTheLinkAndReplacesWhereItPoints) {
  const std::string parent = earlier_output("link");
  fs::create_symlink(parent + "/out", parent + "/link");
  StagedFolder folder(parent + "/link", "test", owned);
  folder.commit([](const std::string& dir) { write_file_atomic(dir + "/c.txt", "via link"); });
  EXPECT_TRUE(fs::is_symlink(parent + "/link"));
  EXPECT_EQ(names_in(parent + "/out"), std::set<std::string>{"c.txt"});
  EXPECT_EQ(read_all(parent + "/link/c.txt"), "via link");
}

TEST(StagedFolder, SyncTreeNamesAFolderItCannotRead) {
  EXPECT_THROW(sync_tree("/nonexistent/f16race/folder"), FileWriteError);
}

}  // namespace
}  // namespace f16race::io
