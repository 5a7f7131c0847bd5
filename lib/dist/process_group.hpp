#pragma once
// One process of a group of f16race processes (ranks) on one or several hosts, over LibTorch's
// own distributed engine: c10d's TCPStore for the rendezvous and ProcessGroupGloo for the
// collectives. Configured the way PyTorch users know: MASTER_ADDR, MASTER_PORT, WORLD_SIZE, RANK
// (what torchrun sets), each overridable by a --dist-* flag (docs/distributed.md).
//
// A lost peer never hangs the group: every rank beats a heartbeat counter in the store, and a
// collective that fails or times out is reported as one line naming the rank(s) that stopped.
#include <cstdint>
#include <functional>
#include <memory>
#include <stdexcept>
#include <string>
#include <vector>

namespace f16race::dist {

struct DistConfig {
  int world_size = 1;  // 1: a single process, no group (nothing below is used)
  int rank = 0;
  std::string master_addr = "127.0.0.1";  // rank 0's host: it serves the store
  int master_port = 29500;
  double timeout_s = 60.0;  // a collective or the rendezvous waiting longer than this fails
};

// Reads WORLD_SIZE, RANK, MASTER_ADDR, MASTER_PORT and F16RACE_DIST_TIMEOUT (seconds) over
// `base`; throws io::InputError naming the variable and the allowed range for a bad value.
DistConfig dist_config_from_environment(DistConfig base = {});
// Range checks of a complete config (flags applied): one line naming the value and the fix.
void validate(const DistConfig& c);

// The peer ranks stopped answering (their process ended or hangs), or the store's host did.
struct PeerLost : std::runtime_error {
  using std::runtime_error::runtime_error;
};

class Group {
 public:
  // Joins the group: rank 0 serves the store, every rank publishes `fingerprint` (what must be
  // equal across ranks: the command's options and this binary) and a rank whose fingerprint
  // differs from rank 0's is refused (io::InputError on every rank, naming it).
  Group(const DistConfig& config, const std::string& fingerprint);
  ~Group();
  Group(const Group&) = delete;
  Group& operator=(const Group&) = delete;

  int rank() const { return config_.rank; }
  int size() const { return config_.world_size; }
  const DistConfig& config() const { return config_; }

  // Element-wise sum over the ranks, in place (int64: exact; float and double: the same bits on
  // every rank, since Gloo reduces each element once and sends the result to all).
  void allreduce_sum(std::vector<std::int64_t>& values);
  void allreduce_sum(std::vector<double>& values);
  void allreduce_sum(float* values, std::size_t n);
  void allreduce_sum(double* values, std::size_t n);
  // Every rank's `mine` (the same length on every rank), concatenated in rank order.
  std::vector<double> allgather(const std::vector<double>& mine);
  // Every rank's bytes (any length), in rank order.
  std::vector<std::string> allgather_bytes(const std::string& mine);
  // Rank 0's `bytes` on every rank (the others' input is replaced).
  void broadcast_bytes(std::string& bytes);
  void barrier();
  // Seconds this process spent inside collectives (waiting for the others included).
  double collective_seconds() const { return collective_s_; }

 private:
  struct Impl;
  DistConfig config_;
  std::unique_ptr<Impl> impl_;
  [[noreturn]] void lost(const std::exception& cause);
  // One collective: runs `op` and turns any failure into lost().
  void collective(const std::function<void()>& op);
  enum class Kind { int64, float32, float64 };
  void allreduce_sum(void* data, std::size_t n, Kind kind);
  double collective_s_ = 0.0;
};

// FNV-1a of this process's executable file: ranks must run the same build.
std::uint64_t executable_hash();

}  // namespace f16race::dist
