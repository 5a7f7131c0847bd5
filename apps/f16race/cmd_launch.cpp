// `f16race launch --nproc N -- SUBCOMMAND ...`: starts N ranks of a subcommand on this host, on
// loopback (dist::run_local_group: the ranks' environment, their group token, the wait for all of
// them). Exit status: the first failing rank's, else 0.
#include <omp.h>

#include <CLI/CLI.hpp>
#include <algorithm>
#include <cstdlib>
#include <memory>
#include <string>
#include <vector>

#include "commands.hpp"
#include "dist/local_launch.hpp"
#include "dist/process_group.hpp"

namespace f16race::app {
namespace {

struct LaunchOptions {
  int nproc = 2;
  int port = 0;  // 0: MASTER_PORT, else a free port
  double timeout_s = 60.0;
  std::vector<std::string> command;
};

// Subcommands that run as ranks of a group; any other would run N times over the same outputs.
void check_ranked(const std::vector<std::string>& command) {
  if (command.empty()) throw io::InputError("launch: give the subcommand after --, e.g. f16race launch --nproc 2 -- tournament --runs ...");
  if (command.front() == "launch") throw io::InputError("launch: the command after -- cannot be launch itself");
  const bool ranked = command.front() == "tournament" || command.front() == "train" ||
                      (command.front() == "bench" && command.size() > 1 && command[1] == "train");
  if (!ranked)
    throw io::InputError("launch: '" + command.front() + "' does not run over ranks; train, tournament and bench "
                         "train do (docs/distributed.md)");
}

}  // namespace

void launch_ranks(int nproc, const std::vector<std::string>& command, int threads_option, double timeout_s, int port_option) {
  check_ranked(command);
  dist::LocalGroup g;
  g.nproc = nproc;
  g.timeout_s = timeout_s;
  g.port = port_option;
  if (g.port == 0) g.port = std::getenv("MASTER_PORT") ? dist::dist_config_from_environment().master_port : dist::free_port_pair();
  // One core's share per rank unless --threads says otherwise: ranks on one host must not
  // oversubscribe it (OpenMP threads spin while they wait).
  const int threads = threads_option > 0 ? threads_option : std::max(1, omp_get_num_procs() / nproc);
  g.argv = {"f16race", "--threads", std::to_string(threads)};
  g.argv.insert(g.argv.end(), command.begin(), command.end());
  if (const int status = dist::run_local_group(g); status != 0) throw ExitStatus{status};
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
