// The study's children: logged, in their own process group, and stopped by the kernel when their
// parent dies, however it died.
#include <gtest/gtest.h>
#include <signal.h>
#include <sys/wait.h>
#include <unistd.h>

#include <chrono>
#include <filesystem>
#include <fstream>
#include <sstream>
#include <stdexcept>
#include <string>
#include <thread>

#include "io/child_process.hpp"
#include "io/input_error.hpp"
#include "io/stale_temporaries.hpp"
#include "support/temp_paths.hpp"

namespace f16race::io {
namespace {

namespace fs = std::filesystem;

std::string read_all(const std::string& path) {
  std::ifstream f(path);
  std::stringstream ss;
  ss << f.rdbuf();
  return ss.str();
}

TEST(ChildProcess, LogsOutputAndReportsTheExitCode) {
  const std::string dir = test_support::fresh_temp_path("child_log");
  fs::create_directories(dir);
  const pid_t pid = spawn_child({"/bin/sh", "-c", "echo out; echo err >&2; exit 3"}, dir + "/x.log");
  EXPECT_EQ(getpgid(pid), pid);  // its own process group: a terminal's Ctrl-C is not sent to it
  int ws = 0;
  ASSERT_EQ(waitpid(pid, &ws, 0), pid);
  EXPECT_EQ(exit_code(ws), 3);
  EXPECT_EQ(read_all(dir + "/x.log"), "out\nerr\n");
}

TEST(ChildProcess, ASignalledChildReportsAsAShellDoes) {
  const pid_t pid = spawn_child({"/bin/sleep", "30"}, "/dev/null");
  kill(pid, SIGINT);
  int ws = 0;
  ASSERT_EQ(waitpid(pid, &ws, 0), pid);
  EXPECT_EQ(exit_code(ws), 130);
}

TEST(ChildProcess, StopsWhenItsParentIsKilled) {
  int fds[2];
  ASSERT_EQ(pipe(fds), 0);
  const pid_t parent = fork();
  if (parent == 0) {  // a parent that starts a long child and dies by SIGKILL
    close(fds[0]);
    const pid_t child = spawn_child({"/bin/sleep", "60"}, "/dev/null");
    (void)!write(fds[1], &child, sizeof child);
    raise(SIGKILL);
  }
  close(fds[1]);
  pid_t child = 0;
  ASSERT_EQ(read(fds[0], &child, sizeof child), static_cast<ssize_t>(sizeof child));
  close(fds[0]);
  int ws = 0;
  waitpid(parent, &ws, 0);
  ASSERT_TRUE(WIFSIGNALED(ws));
  const auto start = std::chrono::steady_clock::now();
  while (process_alive(child) && std::chrono::steady_clock::now() - start < std::chrono::seconds(10))
    std::this_thread::sleep_for(std::chrono::milliseconds(10));
  EXPECT_FALSE(process_alive(child)) << "the orphan of a killed parent still runs (pid " << child << ")";
  if (process_alive(child)) kill(child, SIGKILL);
}

TEST(ChildProcess, ALogThatCannotBeOpenedIsAnInputError) {
  try {
    spawn_child({"/bin/true"}, "/nonexistent/f16race/x.log");
    FAIL() << "started without its log";
  } catch (const InputError& e) {
    EXPECT_EQ(std::string(e.what()).rfind("/nonexistent/f16race/x.log: No such file or directory", 0), 0u) << e.what();
  }
}

TEST(ChildProcess, AProgramThatCannotRunIsNamed) {
  try {
    spawn_child({"/nonexistent/f16race"}, "/dev/null");
    FAIL() << "started a missing program";
  } catch (const std::runtime_error& e) {
    EXPECT_NE(std::string(e.what()).find("cannot start /nonexistent/f16race: cannot execute it"), std::string::npos)
        << e.what();
  }
}

}  // namespace
}  // namespace f16race::io
