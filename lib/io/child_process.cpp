#include "io/child_process.hpp"

#include <fcntl.h>
#include <sys/prctl.h>
#include <sys/wait.h>
#include <unistd.h>

#include <cerrno>
#include <csignal>
#include <cstring>
#include <stdexcept>

#include "io/input_error.hpp"

namespace f16race::io {

namespace {

// What failed between fork and exec, sent to the parent through a close-on-exec pipe: an exec
// that succeeds closes it unwritten.
enum Stage : int { kLog = 1, kDeathSignal = 2, kExec = 3 };

[[noreturn]] void report_and_exit(int pipe_fd, Stage stage) {
  const int msg[2] = {stage, errno};
  (void)!::write(pipe_fd, msg, sizeof msg);
  ::_exit(127);
}

// The child's side, between fork and exec: only async-signal-safe calls (the parent has threads).
[[noreturn]] void become_child(char* const* argv, const char* log_path, pid_t parent, int pipe_fd) {
  ::setpgid(0, 0);
  if (::prctl(PR_SET_PDEATHSIG, SIGTERM) != 0) report_and_exit(pipe_fd, kDeathSignal);
  if (::getppid() != parent) ::_exit(128 + SIGTERM);  // the parent died before prctl took hold
  sigset_t none;
  sigemptyset(&none);
  ::sigprocmask(SIG_SETMASK, &none, nullptr);
  const int fd = ::open(log_path, O_WRONLY | O_CREAT | O_APPEND | O_CLOEXEC, 0644);
  if (fd < 0) report_and_exit(pipe_fd, kLog);
  ::dup2(fd, STDOUT_FILENO);  // the duplicates do not inherit O_CLOEXEC
  ::dup2(fd, STDERR_FILENO);
  ::execv(argv[0], argv);
  report_and_exit(pipe_fd, kExec);
}

}  // namespace

pid_t spawn_child(const std::vector<std::string>& argv_in, const std::string& log_path) {
  if (argv_in.empty()) throw std::runtime_error("spawn_child: no program");
  std::vector<std::string> copy = argv_in;  // built before fork: the child may not allocate
  std::vector<char*> argv;
  for (std::string& a : copy) argv.push_back(a.data());
  argv.push_back(nullptr);
  int fds[2];
  if (::pipe2(fds, O_CLOEXEC) != 0)
    throw std::runtime_error("cannot start " + argv_in[0] + ": " + std::strerror(errno));
  const pid_t parent = ::getpid();
  const pid_t pid = ::fork();
  if (pid < 0) {
    const int err = errno;
    ::close(fds[0]);
    ::close(fds[1]);
    throw std::runtime_error("cannot start " + argv_in[0] + ": " + std::strerror(err));
  }
  if (pid == 0) {
    ::close(fds[0]);
    become_child(argv.data(), log_path.c_str(), parent, fds[1]);
  }
  ::close(fds[1]);
  int msg[2] = {0, 0};
  ssize_t n;
  do n = ::read(fds[0], msg, sizeof msg);
  while (n < 0 && errno == EINTR);
  ::close(fds[0]);
  if (n <= 0) return pid;  // exec succeeded
  ::waitpid(pid, nullptr, 0);
  if (msg[0] == kLog)  // a disk or folder the user can fix
    throw InputError(log_path + ": " + std::strerror(msg[1]) + " while opening the log of " + argv_in[0] +
                     "; free space or fix the folder's permissions");
  const std::string why = msg[0] == kDeathSignal ? "cannot tie it to this process (prctl)" : "cannot execute it";
  throw std::runtime_error("cannot start " + argv_in[0] + ": " + why + ": " + std::strerror(msg[1]));
}

int exit_code(int ws) {
  if (WIFEXITED(ws)) return WEXITSTATUS(ws);
  if (WIFSIGNALED(ws)) return 128 + WTERMSIG(ws);
  return 1;
}

}  // namespace f16race::io
