#pragma once
// One process of a group of f16race processes (ranks) on one or several hosts: the rendezvous
// over rank 0's own key-value stores (token_store.hpp: bound to one address, and a connection
// must present the group's token), the collectives over LibTorch's ProcessGroupGloo. Configured
// the way PyTorch users know: MASTER_ADDR, MASTER_PORT, WORLD_SIZE, RANK (what torchrun sets),
// each overridable by a --dist-* flag, plus F16RACE_GROUP_TOKEN(_FILE) and F16RACE_BIND_ADDR
// (docs/distributed.md).
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
  // The address rank 0's stores listen on; "": loopback, allowed only while MASTER_ADDR is a
  // loopback address (a group of one host).
  std::string bind_addr;
  // The group's shared secret (F16RACE_GROUP_TOKEN or the file F16RACE_GROUP_TOKEN_FILE; never
  // a flag): required for a group of more than one rank.
  std::string token;
};

// Reads WORLD_SIZE, RANK, MASTER_ADDR, MASTER_PORT, F16RACE_DIST_TIMEOUT (seconds),
// F16RACE_BIND_ADDR and, for a group (WORLD_SIZE > 1), the token over `base`; throws
// io::InputError naming the variable and the allowed range for a bad value.
DistConfig dist_config_from_environment(DistConfig base = {});
// Range checks of a complete config (flags applied): one line naming the value and the fix.
void validate(const DistConfig& c);
// Where rank 0's stores listen: bind_addr, else loopback.
std::string store_bind_address(const DistConfig& c);

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
  // The constructor's steps: rank 0 serves the stores, every rank connects and joins; the ranks'
  // fingerprints are compared; the Gloo process group forms over the group's store.
  void connect_stores();
  void agree(const std::string& fingerprint);
  void start_gloo();
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
