#pragma once
// The --dist-* flags of the subcommands that run as one rank of a group (docs/distributed.md):
// each overrides its environment variable (WORLD_SIZE, RANK, MASTER_ADDR, MASTER_PORT,
// F16RACE_DIST_TIMEOUT, F16RACE_BIND_ADDR). The group's token has no flag: a command line is
// readable by every user of the host.
#include <CLI/CLI.hpp>
#include <memory>
#include <string>

#include "dist/group_token.hpp"
#include "dist/process_group.hpp"

namespace f16race::app {

struct DistFlags {
  int world_size = -1, rank = -1, port = -1;  // -1: from the environment (or the default)
  std::string addr, bind;
  double timeout_s = -1.0;

  void add_to(CLI::App* cmd) {
    cmd->add_option("--dist-world-size", world_size, "Ranks in the group (default: WORLD_SIZE, else 1)")
        ->check(CLI::Range(1, 4096));
    cmd->add_option("--dist-rank", rank, "This process's rank (default: RANK, else 0)")->check(CLI::Range(0, 4095));
    cmd->add_option("--dist-addr", addr, "Rank 0's host, which serves the store (default: MASTER_ADDR, else 127.0.0.1)");
    cmd->add_option("--dist-port", port, "The store's port on rank 0's host, which also uses the next one (default: MASTER_PORT, else 29500)")
        ->check(CLI::Range(1, 65534));
    cmd->add_option("--dist-bind", bind,
                    "Rank 0: the address its stores listen on (default: F16RACE_BIND_ADDR, else 127.0.0.1; required "
                    "when MASTER_ADDR is not a loopback address)");
    cmd->add_option("--dist-timeout", timeout_s,
                    "Seconds a rank waits for the others (rendezvous, each collective) before it stops (default: "
                    "F16RACE_DIST_TIMEOUT, else 60)")
        ->check(CLI::Range(1.0, 86400.0));
  }

  dist::DistConfig resolve() const {
    dist::DistConfig c = dist::dist_config_from_environment();
    if (world_size > 0) c.world_size = world_size;
    if (rank >= 0) c.rank = rank;
    if (!addr.empty()) c.master_addr = addr;
    if (port > 0) c.master_port = port;
    if (timeout_s > 0) c.timeout_s = timeout_s;
    if (!bind.empty()) c.bind_addr = bind;
    if (c.world_size > 1 && c.token.empty()) c.token = dist::group_token_from_environment();
    dist::validate(c);
    return c;
  }
};

}  // namespace f16race::app
