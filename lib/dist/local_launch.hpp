#pragma once
// A group of ranks started on this host, on loopback (what torchrun --standalone does for
// PyTorch; `f16race launch`): each rank is a child process with WORLD_SIZE, RANK, LOCAL_RANK,
// MASTER_ADDR and MASTER_PORT set, rank 0's stores bound to 127.0.0.1 (F16RACE_BIND_ADDR) and a
// fresh random group token in F16RACE_GROUP_TOKEN (in the environment, which only this user can
// read, not on the command line). The launcher waits for all of them; when one fails, the others
// stop by themselves (a lost peer ends every collective), and any rank still running after the
// group's timeout is terminated. SIGINT and SIGTERM of the launcher are forwarded to every rank.
#include <string>
#include <vector>

namespace f16race::dist {

// Two adjacent free ports (the lower one returned) for rank 0's stores, outside the kernel's
// ephemeral range: a port from that range can be taken between this check and rank 0's bind by
// any outgoing connection's source port. std::runtime_error when none is found.
int free_port_pair();

struct LocalGroup {
  int nproc = 2;
  int port = 0;            // rank 0's stores: this port and the next
  double timeout_s = 60.0; // the ranks' F16RACE_DIST_TIMEOUT, and how long the others get after a failure
  std::vector<std::string> argv;              // every rank's arguments, argv[0] included
  std::string executable = "/proc/self/exe";  // the program each rank runs
};

// Starts the ranks and waits for all of them. Returns the first failing rank's exit status (128 +
// the signal for a killed one), 0 when every rank succeeded; a failure other than after a
// forwarded signal is named on stderr. Each rank gets SIGTERM when the launcher dies.
int run_local_group(const LocalGroup& group);

}  // namespace f16race::dist
