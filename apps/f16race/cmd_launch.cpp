// `f16race launch --nproc N -- SUBCOMMAND ...`: starts N ranks of a subcommand on this host, on
// loopback (what torchrun --standalone does for PyTorch): each rank is this executable with
// WORLD_SIZE, RANK, LOCAL_RANK, MASTER_ADDR and MASTER_PORT set, rank 0's stores bound to
// 127.0.0.1 (F16RACE_BIND_ADDR) and a fresh random group token in F16RACE_GROUP_TOKEN (in the
// environment, which only this user can read, not on the command line). The launcher waits for all of
// them; when one fails, the others stop by themselves (a lost peer ends every collective), and
// any rank still running after the group's timeout is terminated. Exit status: the first failing
// rank's, else 0.
#include <omp.h>
#include <signal.h>
#include <sys/socket.h>
#include <sys/prctl.h>
#include <sys/wait.h>
#include <netinet/in.h>
#include <unistd.h>

#include <CLI/CLI.hpp>
#include <algorithm>
#include <chrono>
#include <cstdio>
#include <cstdlib>
#include <cstdint>
#include <cstring>
#include <memory>
#include <random>
#include <string>
#include <thread>
#include <utility>
#include <vector>

#include "commands.hpp"
#include "dist/group_token.hpp"
#include "dist/process_group.hpp"

namespace f16race::app {
namespace {

struct LaunchOptions {
  int nproc = 2;
  int port = 0;  // 0: MASTER_PORT, else a free port
  double timeout_s = 60.0;
  std::vector<std::string> command;
};

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

// Two adjacent free ports for rank 0's stores, outside the ephemeral range: a port from that
// range can be taken between this check and rank 0's bind by any outgoing connection's source
// port (a CI run lost a group so: rank 0 could not bind the port after the one it had checked).
int free_port() {
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

std::string describe(int status) {
  if (WIFSIGNALED(status)) return "was killed by signal " + std::to_string(WTERMSIG(status));
  return "exited with status " + std::to_string(WEXITSTATUS(status));
}

int exit_code(int status) { return WIFSIGNALED(status) ? 128 + WTERMSIG(status) : WEXITSTATUS(status); }

}  // namespace

void launch_ranks(int nproc, const std::vector<std::string>& command, int threads_option, double timeout_s, int port_option) {
  LaunchOptions o;
  o.nproc = nproc;
  o.command = command;
  o.timeout_s = timeout_s;
  o.port = port_option;
  if (o.command.empty()) throw io::InputError("launch: give the subcommand after --, e.g. f16race launch --nproc 2 -- tournament --runs ...");
  if (o.command.front() == "launch") throw io::InputError("launch: the command after -- cannot be launch itself");
  // Subcommands that run as ranks of a group; any other would run N times over the same outputs.
  const bool ranked = o.command.front() == "tournament" || o.command.front() == "train" ||
                     (o.command.front() == "bench" && o.command.size() > 1 && o.command[1] == "train");
  if (!ranked)
    throw io::InputError("launch: '" + o.command.front() + "' does not run over ranks; train, tournament and bench "
                         "train do (docs/distributed.md)");
  int port = o.port;
  if (port == 0) {
    const char* env = std::getenv("MASTER_PORT");
    port = env ? dist::dist_config_from_environment().master_port : free_port();
  }
  // One core's share per rank unless --threads says otherwise: ranks on one host must not
  // oversubscribe it (OpenMP threads spin while they wait).
  const int threads = threads_option > 0 ? threads_option : std::max(1, omp_get_num_procs() / o.nproc);
  std::vector<std::string> args{"f16race", "--threads", std::to_string(threads)};
  args.insert(args.end(), o.command.begin(), o.command.end());
  const std::string token = dist::random_group_token();  // this group's alone, made afresh each launch
  std::fflush(stdout);
  std::fflush(stderr);
  g_children.assign(o.nproc, -1);
  const pid_t launcher = ::getpid();
  for (int r = 0; r < o.nproc; ++r) {
    const pid_t pid = ::fork();
    if (pid < 0) throw std::runtime_error("launch: fork failed: " + std::string(std::strerror(errno)));
    if (pid == 0) {
      // A launcher killed outright (SIGKILL) takes its ranks with it: each gets the SIGTERM Ctrl-C
      // would forward, so the group checkpoints and the run folder is free for --resume.
      ::prctl(PR_SET_PDEATHSIG, SIGTERM);
      if (::getppid() != launcher) ::_exit(143);  // it died before prctl took effect
      ::setenv("WORLD_SIZE", std::to_string(o.nproc).c_str(), 1);
      ::setenv("RANK", std::to_string(r).c_str(), 1);
      ::setenv("LOCAL_RANK", std::to_string(r).c_str(), 1);
      ::setenv("MASTER_ADDR", "127.0.0.1", 1);
      ::setenv("MASTER_PORT", std::to_string(port).c_str(), 1);
      ::setenv("F16RACE_DIST_TIMEOUT", std::to_string(static_cast<long>(o.timeout_s)).c_str(), 1);
      ::setenv("F16RACE_BIND_ADDR", "127.0.0.1", 1);
      ::setenv("F16RACE_GROUP_TOKEN", token.c_str(), 1);
      ::unsetenv("F16RACE_GROUP_TOKEN_FILE");  // the launcher's token, not one the user's shell names
      std::vector<char*> argv;
      for (const std::string& a : args) argv.push_back(const_cast<char*>(a.c_str()));
      argv.push_back(nullptr);
      ::execv("/proc/self/exe", argv.data());
      std::fprintf(stderr, "f16race launch: cannot start rank %d: %s\n", r, std::strerror(errno));
      ::_exit(127);
    }
    g_children[r] = pid;
  }
  struct sigaction sa {};
  sa.sa_handler = forward_signal;
  ::sigaction(SIGINT, &sa, nullptr);
  ::sigaction(SIGTERM, &sa, nullptr);

  int first_failure = 0, running = o.nproc;
  auto deadline = std::chrono::steady_clock::time_point::max();
  bool terminated = false;
  while (running > 0) {
    int status = 0;
    const pid_t pid = ::waitpid(-1, &status, WNOHANG);
    if (pid < 0 && errno == EINTR) continue;
    if (pid < 0) break;
    if (pid == 0) {
      // After a failure the others get the group's timeout (plus the diagnosis) to stop by themselves.
      if (std::chrono::steady_clock::now() > deadline) {
        for (std::size_t r = 0; r < g_children.size(); ++r)
          if (g_children[r] > 0) {
            std::fprintf(stderr, "f16race launch: rank %zu still runs %.0f s after the failure; %s it\n", r,
                         o.timeout_s, terminated ? "killing" : "terminating");
            ::kill(g_children[r], terminated ? SIGKILL : SIGTERM);
            ::kill(g_children[r], SIGCONT);  // a stopped rank takes its SIGTERM only once it runs
          }
        terminated = true;
        deadline = std::chrono::steady_clock::now() + std::chrono::seconds(5);
      }
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
                   describe(status).c_str(), o.timeout_s);
      first_failure = exit_code(status);
      deadline = std::chrono::steady_clock::now() + std::chrono::milliseconds(static_cast<long>(o.timeout_s * 1000) + 5000);
    }
  }
  g_children.clear();
  if (first_failure != 0) throw ExitStatus{first_failure};
}

void add_launch_command(CLI::App& app, const int& threads_option) {
  auto o = std::make_shared<LaunchOptions>();
  CLI::App* cmd = app.add_subcommand(
      "launch", "Start N ranks of a distributed subcommand on this host: f16race launch --nproc 2 -- tournament ...");
  cmd->add_option("--nproc", o->nproc, "Ranks to start")->check(CLI::Range(1, 256));
  cmd->add_option("--port", o->port,
                  "The stores' port on 127.0.0.1, and the one after it (default: MASTER_PORT, else two free ones)")
      ->check(CLI::Range(1, 65534));
  cmd->add_option("--timeout", o->timeout_s, "Seconds a rank waits for a lost peer before it stops")
      ->check(CLI::Range(1.0, 86400.0));
  cmd->add_option("command", o->command, "The subcommand and its arguments, after --")->required();
  const int* threads = &threads_option;
  cmd->callback([o, threads]() { launch_ranks(o->nproc, o->command, *threads, o->timeout_s, o->port); });
}

}  // namespace f16race::app
