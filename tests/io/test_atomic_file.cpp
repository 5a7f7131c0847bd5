// The one file writer: a failed write (full disk, file-size limit, missing folder) leaves the old
// file and no temporary, and says so in one line; a failed append leaves the log as it was.
#include <gtest/gtest.h>
#include <sys/resource.h>

#include <csignal>
#include <filesystem>
#include <fstream>
#include <sstream>
#include <string>

#include "io/atomic_file.hpp"
#include "support/temp_paths.hpp"

namespace f16race::io {
namespace {

namespace fs = std::filesystem;

std::string fresh_dir(const std::string& name) {
  const std::string p = test_support::fresh_temp_path("atomic_file_" + name);
  fs::create_directories(p);
  return p;
}

std::string read_all(const std::string& path) {
  std::ifstream f(path, std::ios::binary);
  std::stringstream ss;
  ss << f.rdbuf();
  return ss.str();
}

int temporaries_in(const std::string& dir) {
  int n = 0;
  for (const auto& e : fs::directory_iterator(dir)) n += e.path().filename().string().find(".tmp.") != std::string::npos;
  return n;
}

// Lowers the file-size limit for the scope: writes past it fail with EFBIG like a full disk.
class FileSizeLimit {
 public:
  explicit FileSizeLimit(rlim_t bytes) {
    getrlimit(RLIMIT_FSIZE, &old_);
    old_handler_ = std::signal(SIGXFSZ, SIG_IGN);  // else the kernel ends the process
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

TEST(AtomicFile, FailedWriteKeepsTheOldFileAndLeavesNoTemporary) {
  const std::string dir = fresh_dir("limit");
  const std::string path = dir + "/summary.json";
  write_file_atomic(path, "old");
  try {
    FileSizeLimit limit(64);
    write_file_atomic(path, std::string(4096, 'x'));
    FAIL() << "a write past the file-size limit succeeded";
  } catch (const FileWriteError& e) {
    const std::string m = e.what();
    EXPECT_EQ(m.rfind(path + ": ", 0), 0u) << m;
    EXPECT_NE(m.find("while writing; nothing else was changed"), std::string::npos) << m;
    EXPECT_EQ(m.find('\n'), std::string::npos) << m;
  }
  EXPECT_EQ(read_all(path), "old");
  EXPECT_EQ(temporaries_in(dir), 0);
  write_file_atomic(path, "new");  // and the next write, with room, goes through
  EXPECT_EQ(read_all(path), "new");
}

TEST(AtomicFile, CreatesMissingFoldersAndRefusesAFileInTheWay) {
  const std::string dir = fresh_dir("folders");
  write_file_atomic(dir + "/a/b/c.txt", "text");
  EXPECT_EQ(read_all(dir + "/a/b/c.txt"), "text");
  try {
    write_file_atomic(dir + "/a/b/c.txt/d.txt", "x");
    FAIL() << "wrote below a regular file";
  } catch (const FileWriteError& e) {
    EXPECT_NE(std::string(e.what()).find("cannot create its folder"), std::string::npos) << e.what();
  }
}

TEST(AtomicFile, FailedAppendReportsTheFullDevice) {
  try {
    append_file("/dev/full", "row\n");  // every write: ENOSPC
    FAIL() << "an append to /dev/full succeeded";
  } catch (const FileWriteError& e) {
    EXPECT_NE(std::string(e.what()).find("/dev/full: no space left on device while appending"), std::string::npos)
        << e.what();
  }
}

TEST(AtomicFile, FailedAppendLeavesTheLogAsItWas) {
  const std::string dir = fresh_dir("append");
  const std::string path = dir + "/metrics.csv";
  append_file(path, "a,b\n");
  append_file(path, "1,2\n");
  {
    FileSizeLimit limit(16);
    EXPECT_THROW(append_file(path, std::string(100, '9') + "\n"), FileWriteError);
  }
  EXPECT_EQ(read_all(path), "a,b\n1,2\n");
}

}  // namespace
}  // namespace f16race::io
