#include "dist/local_launch.hpp"

#include <netinet/in.h>
#include <signal.h>
#include <sys/prctl.h>
#include <sys/socket.h>
#include <sys/wait.h>
#include <unistd.h>

#include <algorithm>
#include <cerrno>
#include <chrono>
#include <cstdint>
#include <cstdio>
#include <cstdlib>
#include <cstring>
#include <random>
#include <stdexcept>
#include <thread>
#include <utility>

#include "dist/group_token.hpp"

namespace f16race::dist {
namespace {

// Forwarded to every rank: Ctrl-C of the launcher is Ctrl-C of the group.
std::vector<pid_t> g_children;
volatile sig_atomic_t g_forwarded = 0;  // the user stopped the group: its ranks' exits are no failure
extern "C" void forward_signal(int sig) {
  g_forwarded = 1;
  for (pid_t p : g_children)
    if (p > 0) ::kill(p, sig);
}

// Whether a socket of `family` binds to `a` (closed again at once): 1 yes, 0 no, -1 the host has
// no such sockets.
int binds(int family, const sockaddr* a, socklen_t len) {
  const int fd = ::socket(family, SOCK_STREAM, 0);
  if (fd < 0) return -1;
  const int ok = ::bind(fd, a, len) == 0 ? 1 : 0;
  ::close(fd);
  return ok;
}

// Whether a listening socket can take `port` on every address (IPv6 any, dual-stack, where the
// host has IPv6; else IPv4 any): stricter than rank 0's stores need (127.0.0.1 alone), so a port
// some other program holds on any address is passed over too.
bool port_free(int port) {
  if (port < 1 || port > 65535) return false;
  const auto p = htons(static_cast<std::uint16_t>(port));
  sockaddr_in6 a6{};
  a6.sin6_family = AF_INET6;
  a6.sin6_addr = in6addr_any;
  a6.sin6_port = p;
  const int v6 = binds(AF_INET6, reinterpret_cast<const sockaddr*>(&a6), sizeof a6);
  if (v6 >= 0) return v6 == 1;
  sockaddr_in a4{};
  a4.sin_family = AF_INET;
  a4.sin_addr.s_addr = htonl(INADDR_ANY);
  a4.sin_port = p;
  return binds(AF_INET, reinterpret_cast<const sockaddr*>(&a4), sizeof a4) == 1;
}

// The kernel's ephemeral range: the source ports of outgoing connections (the ranks' own store
// and Gloo sockets among them) and of bind(0).
std::pair<int, int> ephemeral_ports() {
  int lo = 32768, hi = 60999;  // Linux's default
  if (std::FILE* f = std::fopen("/proc/sys/net/ipv4/ip_local_port_range", "r")) {
    int a = 0, b = 0;
    if (std::fscanf(f, "%d %d", &a, &b) == 2 && a >= 1 && a <= b) lo = a, hi = b;
    std::fclose(f);
  }
  return {lo, hi};
}

std::string describe(int status) {
  if (WIFSIGNALED(status)) return "was killed by signal " + std::to_string(WTERMSIG(status));
  return "exited with status " + std::to_string(WEXITSTATUS(status));
}

int exit_code(int status) { return WIFSIGNALED(status) ? 128 + WTERMSIG(status) : WEXITSTATUS(status); }

// In the child: the group's environment, then the rank's program. Never returns.
[[noreturn]] void exec_rank(const LocalGroup& g, int r, const std::string& token) {
  ::setenv("WORLD_SIZE", std::to_string(g.nproc).c_str(), 1);
  ::setenv("RANK", std::to_string(r).c_str(), 1);
  ::setenv("LOCAL_RANK", std::to_string(r).c_str(), 1);
  ::setenv("MASTER_ADDR", "127.0.0.1", 1);
  ::setenv("MASTER_PORT", std::to_string(g.port).c_str(), 1);
  ::setenv("F16RACE_DIST_TIMEOUT", std::to_string(static_cast<long>(g.timeout_s)).c_str(), 1);
  ::setenv("F16RACE_BIND_ADDR", "127.0.0.1", 1);
  ::setenv("F16RACE_GROUP_TOKEN", token.c_str(), 1);
  ::unsetenv("F16RACE_GROUP_TOKEN_FILE");  // the launcher's token, not one the user's shell names
  std::vector<char*> argv;
  for (const std::string& a : g.argv) argv.push_back(const_cast<char*>(a.c_str()));
  argv.push_back(nullptr);
  ::execv(g.executable.c_str(), argv.data());
  std::fprintf(stderr, "f16race launch: cannot start rank %d: %s\n", r, std::strerror(errno));
  ::_exit(127);
}

// Forks every rank into g_children.
void start_ranks(const LocalGroup& g) {
  const std::string token = random_group_token();  // this group's alone, made afresh each launch
  std::fflush(stdout);
  std::fflush(stderr);
  g_children.assign(g.nproc, -1);
  const pid_t launcher = ::getpid();
  for (int r = 0; r < g.nproc; ++r) {
    const pid_t pid = ::fork();
    if (pid < 0) throw std::runtime_error("launch: fork failed: " + std::string(std::strerror(errno)));
    if (pid == 0) {
      // A launcher killed outright (SIGKILL) takes its ranks with it: each gets the SIGTERM Ctrl-C
      // would forward, so the group checkpoints and the run folder is free for --resume.
      ::prctl(PR_SET_PDEATHSIG, SIGTERM);
      if (::getppid() != launcher) ::_exit(143);  // it died before prctl took effect
      exec_rank(g, r, token);
    }
    g_children[r] = pid;
  }
}

// Once past `deadline` (a failure plus the group's timeout): SIGTERM to every rank still
// running, SIGKILL 5 s later.
void stop_stragglers(const LocalGroup& g, std::chrono::steady_clock::time_point* deadline, bool* terminated) {
  if (std::chrono::steady_clock::now() <= *deadline) return;
  for (std::size_t r = 0; r < g_children.size(); ++r)
    if (g_children[r] > 0) {
      std::fprintf(stderr, "f16race launch: rank %zu still runs %.0f s after the failure; %s it\n", r, g.timeout_s,
                   *terminated ? "killing" : "terminating");
      ::kill(g_children[r], *terminated ? SIGKILL : SIGTERM);
      ::kill(g_children[r], SIGCONT);  // a stopped rank takes its SIGTERM only once it runs
    }
  *terminated = true;
  *deadline = std::chrono::steady_clock::now() + std::chrono::seconds(5);
}

}  // namespace

int free_port_pair() {
  const auto [eph_lo, eph_hi] = ephemeral_ports();
  std::vector<std::pair<int, int>> ranges;  // [first, last] candidates for the lower port
  if (eph_lo - 2 >= 10000) ranges.emplace_back(10000, eph_lo - 2);
  if (eph_hi + 1 <= 65533) ranges.emplace_back(eph_hi + 1, 65533);
  if (ranges.empty()) ranges.emplace_back(1024, 65533);  // the whole range is ephemeral: no safe side
  std::random_device rd;
  std::mt19937 gen(rd());
  for (int attempt = 0; attempt < 200; ++attempt) {
    const auto& r = ranges[gen() % ranges.size()];
    const int port = r.first + static_cast<int>(gen() % static_cast<unsigned>(r.second - r.first + 1));
    if (port_free(port) && port_free(port + 1)) return port;
  }
  throw std::runtime_error("launch: found no two adjacent free ports outside the ephemeral range; give one with launch --port");
}

int run_local_group(const LocalGroup& g) {
  start_ranks(g);
  struct sigaction sa {};
  sa.sa_handler = forward_signal;
  ::sigaction(SIGINT, &sa, nullptr);
  ::sigaction(SIGTERM, &sa, nullptr);

  int first_failure = 0, running = g.nproc;
  auto deadline = std::chrono::steady_clock::time_point::max();
  bool terminated = false;
  while (running > 0) {
    int status = 0;
    const pid_t pid = ::waitpid(-1, &status, WNOHANG);
    if (pid < 0 && errno == EINTR) continue;
    if (pid < 0) break;
    if (pid == 0) {
      // After a failure the others get the group's timeout (plus the diagnosis) to stop by themselves.
      stop_stragglers(g, &deadline, &terminated);
      std::this_thread::sleep_for(std::chrono::milliseconds(50));
      continue;
    }
    const auto it = std::find(g_children.begin(), g_children.end(), pid);
    if (it == g_children.end()) continue;
    const int r = static_cast<int>(it - g_children.begin());
    *it = -1;
    --running;
    if (status != 0 && first_failure == 0 && g_forwarded) {
      first_failure = exit_code(status);  // e.g. 130 after a checkpoint: the rank says so itself
    } else if (status != 0 && first_failure == 0) {
      std::fprintf(stderr, "f16race launch: rank %d %s; the other ranks stop within %.0f s\n", r,
                   describe(status).c_str(), g.timeout_s);
      first_failure = exit_code(status);
      deadline = std::chrono::steady_clock::now() + std::chrono::milliseconds(static_cast<long>(g.timeout_s * 1000) + 5000);
    }
  }
  g_children.clear();
  return first_failure;
}

}  // namespace f16race::dist
