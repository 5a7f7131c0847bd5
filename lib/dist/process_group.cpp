#include "dist/process_group.hpp"

// The Gloo process group is compiled into Debian's libtorch_cpu; its header needs this switch
// (Torch's CMake config sets it) and libgloo-dev's headers.
#ifndef USE_C10D_GLOO
#define USE_C10D_GLOO
#endif
#include <torch/csrc/distributed/c10d/ProcessGroupGloo.hpp>
#include <torch/torch.h>

#include <algorithm>
#include <atomic>
#include <cerrno>
#include <chrono>
#include <cstdio>
#include <cstdlib>
#include <fstream>
#include <sstream>
#include <thread>

#include "dist/group_token.hpp"
#include "dist/token_store.hpp"
#include "dist/token_store_server.hpp"
#include "io/byte_hash.hpp"
#include "io/input_error.hpp"

// glog's threshold (libc10 logs through Debian's glog): c10d's code logs a failure with a glog
// banner before it throws, which would bury this program's one-line message.
namespace fLI {
extern int FLAGS_minloglevel;
}

namespace f16race::dist {

namespace {

// Quiets glog for its lifetime (FATAL only), around c10d calls whose failure we report ourselves.
struct QuietGlog {
  int saved = fLI::FLAGS_minloglevel;
  QuietGlog() { fLI::FLAGS_minloglevel = 3; }
  ~QuietGlog() { fLI::FLAGS_minloglevel = saved; }
};

using Clock = std::chrono::steady_clock;
constexpr auto kHeartbeatPeriod = std::chrono::milliseconds(200);
// A rank whose counter does not move for this long is taken for stopped (5 missed beats).
constexpr auto kHeartbeatStale = std::chrono::milliseconds(1000);

std::string first_line(const std::string& s) {
  const std::string line = s.substr(0, s.find('\n'));
  return line.size() > 200 ? line.substr(0, 200) + "..." : line;
}

long parse_long(const char* name, const char* text, long lo, long hi) {
  char* end = nullptr;
  errno = 0;
  const long v = std::strtol(text, &end, 10);
  if (errno != 0 || end == text || *end != '\0' || v < lo || v > hi)
    throw io::InputError(std::string(name) + "=" + text + ": expected an integer in [" + std::to_string(lo) + ", " +
                         std::to_string(hi) + "]");
  return v;
}

bool is_loopback(const std::string& host) {
  return host == "localhost" || host.rfind("127.", 0) == 0 || host == "::1";
}

std::chrono::milliseconds millis(double seconds) {
  return std::chrono::milliseconds(static_cast<std::int64_t>(seconds * 1000.0));
}

// Rank 0 serves two stores: the group's (MASTER_PORT: rendezvous, fingerprints, Gloo's own
// rendezvous) and the heartbeats' (MASTER_PORT + 1), so the diagnosis of a lost rank reads its
// counters on a server the group's traffic never held up.
enum class StoreUse { group, heartbeats };
int store_port(const DistConfig& c, StoreUse use) { return c.master_port + (use == StoreUse::heartbeats ? 1 : 0); }

StoreServerOptions server_options(const DistConfig& c, StoreUse use) {
  StoreServerOptions o;
  o.bind_address = store_bind_address(c);
  o.port = store_port(c, use);
  o.token = c.token;
  o.name = use == StoreUse::group ? "the group's store" : "the heartbeats' store";
  // A stranger is named on rank 0's stderr; the run goes on.
  o.log = [](const std::string& line) { std::fprintf(stderr, "f16race: rank 0: %s\n", line.c_str()); };
  return o;
}

c10::intrusive_ptr<TokenStore> connect_store(const DistConfig& c, StoreUse use, std::chrono::milliseconds timeout) {
  return c10::make_intrusive<TokenStore>(c.master_addr, store_port(c, use), c.token, timeout);
}

std::string hb_key(int rank) { return "f16race/heartbeat/" + std::to_string(rank); }
// The rendezvous: every rank adds itself; the last to join sets the flag rank 0 waits for.
const std::string kJoinedKey = "f16race/joined";
const std::string kAllJoinedKey = "f16race/all_joined";

}  // namespace

DistConfig dist_config_from_environment(DistConfig c) {
  if (const char* v = std::getenv("WORLD_SIZE")) c.world_size = static_cast<int>(parse_long("WORLD_SIZE", v, 1, 4096));
  if (const char* v = std::getenv("RANK")) c.rank = static_cast<int>(parse_long("RANK", v, 0, 4095));
  if (const char* v = std::getenv("MASTER_ADDR")) c.master_addr = v;
  if (const char* v = std::getenv("MASTER_PORT")) c.master_port = static_cast<int>(parse_long("MASTER_PORT", v, 1, 65534));
  if (const char* v = std::getenv("F16RACE_DIST_TIMEOUT"))
    c.timeout_s = static_cast<double>(parse_long("F16RACE_DIST_TIMEOUT", v, 1, 86400));
  if (const char* v = std::getenv("F16RACE_BIND_ADDR")) c.bind_addr = v;
  if (c.world_size > 1 && c.token.empty()) c.token = group_token_from_environment();
  return c;
}

void validate(const DistConfig& c) {
  if (c.world_size < 1) throw io::InputError("world size " + std::to_string(c.world_size) + ": must be at least 1");
  if (c.rank < 0 || c.rank >= c.world_size)
    throw io::InputError("rank " + std::to_string(c.rank) + " is outside a group of " + std::to_string(c.world_size) +
                         ": RANK (--dist-rank) must be in [0, WORLD_SIZE - 1]");
  if (c.master_port < 1 || c.master_port > 65534)
    throw io::InputError("master port " + std::to_string(c.master_port) +
                         ": MASTER_PORT must be in [1, 65534] (rank 0 also listens on the port after it)");
  if (c.master_addr.empty()) throw io::InputError("MASTER_ADDR is empty: give rank 0's host name or address");
  if (!(c.timeout_s >= 1.0)) throw io::InputError("distributed timeout must be at least 1 s");
  if (c.world_size > 1 && c.token.empty())
    throw io::InputError("a group of " + std::to_string(c.world_size) +
                         " ranks needs its shared token: set F16RACE_GROUP_TOKEN (or F16RACE_GROUP_TOKEN_FILE) to the "
                         "same secret on every rank (launch sets one itself)");
  if (c.world_size > 1 && c.rank == 0 && c.bind_addr.empty() && !is_loopback(c.master_addr))
    throw io::InputError("rank 0 serves ranks on other hosts (MASTER_ADDR=" + c.master_addr +
                         "): set F16RACE_BIND_ADDR (--dist-bind) to this host's address they connect to (0.0.0.0: "
                         "every interface)");
}

std::string store_bind_address(const DistConfig& c) {
  if (!c.bind_addr.empty()) return c.bind_addr;
  return c.master_addr == "::1" ? "::1" : "127.0.0.1";
}

std::uint64_t executable_hash() {
  std::ifstream in("/proc/self/exe", std::ios::binary);
  std::uint64_t h = io::kFnv1aOffset;
  std::vector<char> buf(1 << 20);
  while (in) {
    in.read(buf.data(), static_cast<std::streamsize>(buf.size()));
    h = io::fnv1a(buf.data(), static_cast<std::size_t>(in.gcount()), h);
  }
  return h;
}

struct Group::Impl {
  // Rank 0: the two stores it serves (declared first: they outlive the clients below).
  std::unique_ptr<TokenStoreServer> store_server, beats_server;
  c10::intrusive_ptr<TokenStore> store;
  c10::intrusive_ptr<TokenStore> beats;  // the heartbeats' store
  c10::intrusive_ptr<c10d::ProcessGroupGloo> pg;
  std::atomic<bool> stop{false};
  std::thread heartbeat;
  // Also when the Group's constructor throws after the heartbeat started.
  ~Impl() {
    stop = true;
    if (heartbeat.joinable()) heartbeat.join();
  }
};

Group::Group(const DistConfig& config, const std::string& fingerprint) : config_(config), impl_(std::make_unique<Impl>()) {
  validate(config_);
  const DistConfig& c = config_;
  connect_stores();
  // Heartbeats on a connection of their own (one request at a time per connection).
  impl_->beats->add(hb_key(c.rank), 1);
  Impl* impl = impl_.get();
  impl_->heartbeat = std::thread([impl, c]() {
    try {
      TokenStore beat(c.master_addr, store_port(c, StoreUse::heartbeats), c.token, std::chrono::seconds(5));
      while (!impl->stop.load()) {
        beat.add(hb_key(c.rank), 1);
        std::this_thread::sleep_for(kHeartbeatPeriod);
      }
    } catch (const std::exception&) {
      // The store's host is gone: the next collective fails and lost() names rank 0.
    }
  });
  agree(fingerprint);
  start_gloo();
}

void Group::connect_stores() {
  const DistConfig& c = config_;
  const std::string me = "rank " + std::to_string(c.rank) + " of " + std::to_string(c.world_size);
  if (c.rank == 0) {
    try {
      impl_->store_server = std::make_unique<TokenStoreServer>(server_options(c, StoreUse::group));
      impl_->beats_server = std::make_unique<TokenStoreServer>(server_options(c, StoreUse::heartbeats));
    } catch (const std::exception& e) {
      throw io::InputError(me + ": cannot serve the stores on " + store_bind_address(c) + " port " +
                           std::to_string(c.master_port) + " and the port after it (" + first_line(e.what()) +
                           "): choose another MASTER_PORT (--dist-port), or an address of this host as "
                           "F16RACE_BIND_ADDR (--dist-bind)");
    }
  }
  const std::string where = c.master_addr + ":" + std::to_string(c.master_port);
  try {
    impl_->store = connect_store(c, StoreUse::group, millis(c.timeout_s));
    impl_->beats = connect_store(c, StoreUse::heartbeats, millis(c.timeout_s));
  } catch (const TokenRefused& e) {
    throw io::InputError(me + ": " + e.what() +
                         ": give every rank the same F16RACE_GROUP_TOKEN (or F16RACE_GROUP_TOKEN_FILE)");
  } catch (const std::exception& e) {
    throw io::InputError(me + ": no group at " + where + " within " + std::to_string(static_cast<int>(c.timeout_s)) +
                         " s (" + first_line(e.what()) + "): start rank 0 there, or fix MASTER_ADDR/MASTER_PORT");
  }
  // Rank 0 goes on once every rank has joined, or stops at the timeout saying how many did.
  try {
    if (impl_->store->add(kJoinedKey, 1) == c.world_size) impl_->store->set(kAllJoinedKey, {1});
  } catch (const std::exception& e) {
    lost(e);  // rank 0's store went away just after this rank connected
  }
  if (c.rank != 0) return;
  try {
    impl_->store->wait({kAllJoinedKey});
  } catch (const std::exception&) {
    std::string joined = "not every rank";
    try {
      joined = std::to_string(impl_->store->add(kJoinedKey, 0)) + " of " + std::to_string(c.world_size) + " ranks";
    } catch (const std::exception&) {
    }
    throw io::InputError(me + ": " + joined + " joined within " + std::to_string(static_cast<int>(c.timeout_s)) +
                         " s: start every rank with MASTER_ADDR/MASTER_PORT naming " + where +
                         " and the group's token (rank 0's stderr names each connection it dropped)");
  }
}

void Group::agree(const std::string& fingerprint) {
  const DistConfig& c = config_;
  const std::string me = "rank " + std::to_string(c.rank) + " of " + std::to_string(c.world_size);
  // Everything that must agree (options, binary): rank 0 compares every rank's with its own.
  const std::string fp_key = "f16race/fingerprint/";
  std::string verdict = "ok";
  try {  // a rank lost during the exchange is reported as any lost rank
  impl_->store->set(fp_key + std::to_string(c.rank), std::vector<std::uint8_t>(fingerprint.begin(), fingerprint.end()));
  if (c.rank == 0) {
    for (int q = 1; q < c.world_size && verdict == "ok"; ++q) {
      const auto other = impl_->store->get(fp_key + std::to_string(q));
      const std::string theirs(other.begin(), other.end());
      if (theirs == fingerprint) continue;
      std::istringstream a(fingerprint), b(theirs);
      std::string la, lb;
      while (std::getline(a, la) && std::getline(b, lb) && la == lb) {
      }
      verdict = "rank " + std::to_string(q) + " runs another command or build than rank 0 (rank 0: '" +
                first_line(la) + "', rank " + std::to_string(q) + ": '" + first_line(lb) +
                "'): start every rank with the same binary and arguments";
    }
    impl_->store->set("f16race/verdict", std::vector<std::uint8_t>(verdict.begin(), verdict.end()));
    // Rank 0 serves the store: it stays until every rank has read the verdict, so a refused
    // rank hears why instead of losing the connection.
    if (verdict != "ok") {
      std::vector<std::string> read;
      for (int q = 1; q < c.world_size; ++q) read.push_back("f16race/verdict_read/" + std::to_string(q));
      try {
        impl_->store->wait(read);
      } catch (const std::exception&) {
        // A rank that never reads it stops at its own timeout; this one has its message.
      }
    }
  } else {
    const auto v = impl_->store->get("f16race/verdict");
    verdict.assign(v.begin(), v.end());
    impl_->store->set("f16race/verdict_read/" + std::to_string(c.rank), std::vector<std::uint8_t>{1});
  }
  } catch (const std::exception& e) {
    lost(e);
  }
  if (verdict != "ok") throw io::InputError(me + ": " + verdict);
}

void Group::start_gloo() {
  const DistConfig& c = config_;
  const std::string me = "rank " + std::to_string(c.rank) + " of " + std::to_string(c.world_size);
  auto options = c10d::ProcessGroupGloo::Options::create(millis(c.timeout_s));
  if (const char* ifname = std::getenv("GLOO_SOCKET_IFNAME")) {
    try {
      options->devices.push_back(c10d::ProcessGroupGloo::createDeviceForInterface(ifname));
    } catch (const std::exception& e) {
      throw io::InputError(me + ": GLOO_SOCKET_IFNAME=" + ifname + " is not a usable interface (" +
                           first_line(e.what()) + "): name one that `ip link` lists, or unset it");
    }
  } else if (is_loopback(c.master_addr))
    options->devices.push_back(c10d::ProcessGroupGloo::createDeviceForHostname("127.0.0.1"));
  else
    options->devices.push_back(c10d::ProcessGroupGloo::createDefaultDevice());
  try {
    QuietGlog quiet;
    impl_->pg = c10::make_intrusive<c10d::ProcessGroupGloo>(impl_->store, c.rank, c.world_size, options);
  } catch (const std::exception& e) {
    lost(e);
  }
}

Group::~Group() = default;

void Group::lost(const std::exception& cause) {
  const DistConfig& c = config_;
  const std::string me = "rank " + std::to_string(c.rank) + " of " + std::to_string(c.world_size);
  std::string who;
  try {
    // Which ranks stopped beating: two reads of every counter, kHeartbeatStale apart.
    TokenStore probe(c.master_addr, store_port(c, StoreUse::heartbeats), c.token, std::chrono::seconds(3));
    std::vector<std::int64_t> before(c.world_size);
    for (int q = 0; q < c.world_size; ++q) before[q] = probe.add(hb_key(q), 0);
    std::this_thread::sleep_for(kHeartbeatStale);
    for (int q = 0; q < c.world_size; ++q)
      if (q != c.rank && probe.add(hb_key(q), 0) == before[q]) who += (who.empty() ? "" : ", ") + std::to_string(q);
    if (!who.empty()) who = "rank " + who + " is not running (no heartbeat for 1 s: its process ended, hangs or never joined)";
  } catch (const std::exception& e) {
    who = c.rank != 0 ? "rank 0 stopped (its store at " + c.master_addr + ":" + std::to_string(c.master_port + 1) +
                            " is gone)"
                      : "the group's heartbeats could not be read (" + first_line(e.what()) + ")";
  }
  if (who.empty())
    who = "a collective failed with every rank's heartbeat alive (a rank is stuck, or the network between hosts is "
          "blocked: GLOO_SOCKET_IFNAME)";
  throw PeerLost(me + ": " + who + "; stopping (" + first_line(cause.what()) + ")");
}

void Group::collective(const std::function<void()>& op) {
  c10::InferenceMode normal_tensors(false);  // Gloo updates its tensors in place on its own thread
  const auto t0 = Clock::now();
  try {
    op();
  } catch (const std::exception& e) {
    lost(e);
  }
  collective_s_ += std::chrono::duration<double>(Clock::now() - t0).count();
}

void Group::allreduce_sum(void* data, std::size_t n, Kind kind) {
  if (n == 0) return;
  const auto dtype = kind == Kind::int64 ? torch::kInt64 : kind == Kind::float32 ? torch::kFloat32 : torch::kFloat64;
  collective([&]() {
    std::vector<at::Tensor> t{torch::from_blob(data, {static_cast<std::int64_t>(n)}, dtype)};
    impl_->pg->allreduce(t)->wait();
  });
}

void Group::allreduce_sum(std::vector<std::int64_t>& values) { allreduce_sum(values.data(), values.size(), Kind::int64); }
void Group::allreduce_sum(std::vector<double>& values) { allreduce_sum(values.data(), values.size(), Kind::float64); }
void Group::allreduce_sum(float* values, std::size_t n) { allreduce_sum(values, n, Kind::float32); }
void Group::allreduce_sum(double* values, std::size_t n) { allreduce_sum(values, n, Kind::float64); }

std::vector<double> Group::allgather(const std::vector<double>& mine) {
  const auto n = static_cast<std::int64_t>(mine.size());
  std::vector<double> all(mine.size() * static_cast<std::size_t>(size()));
  if (mine.empty()) return all;
  collective([&]() {
    std::vector<at::Tensor> in{torch::from_blob(const_cast<double*>(mine.data()), {n}, torch::kFloat64)};
    std::vector<std::vector<at::Tensor>> out(1);
    for (int q = 0; q < size(); ++q) out[0].push_back(torch::from_blob(all.data() + q * n, {n}, torch::kFloat64));
    impl_->pg->allgather(out, in)->wait();
  });
  return all;
}

std::vector<std::string> Group::allgather_bytes(const std::string& mine) {
  // Lengths first, then every rank's bytes padded to the longest.
  std::vector<std::int64_t> lengths(static_cast<std::size_t>(size()), 0);
  lengths[static_cast<std::size_t>(rank())] = static_cast<std::int64_t>(mine.size());
  allreduce_sum(lengths);
  const std::int64_t longest = std::max<std::int64_t>(1, *std::max_element(lengths.begin(), lengths.end()));
  std::string padded = mine;
  padded.resize(static_cast<std::size_t>(longest), '\0');
  std::string all(static_cast<std::size_t>(longest * size()), '\0');
  collective([&]() {
    std::vector<at::Tensor> in{torch::from_blob(padded.data(), {longest}, torch::kUInt8)};
    std::vector<std::vector<at::Tensor>> out(1);
    for (int q = 0; q < size(); ++q) out[0].push_back(torch::from_blob(all.data() + q * longest, {longest}, torch::kUInt8));
    impl_->pg->allgather(out, in)->wait();
  });
  std::vector<std::string> result;
  for (int q = 0; q < size(); ++q)
    result.emplace_back(all.data() + q * longest, static_cast<std::size_t>(lengths[static_cast<std::size_t>(q)]));
  return result;
}

void Group::broadcast_bytes(std::string& bytes) {
  std::vector<std::int64_t> length{rank() == 0 ? static_cast<std::int64_t>(bytes.size()) : 0};
  allreduce_sum(length);
  bytes.resize(static_cast<std::size_t>(length[0]));
  if (length[0] == 0) return;
  collective([&]() {
    std::vector<at::Tensor> t{torch::from_blob(bytes.data(), {length[0]}, torch::kUInt8)};
    impl_->pg->broadcast(t)->wait();
  });
}

void Group::barrier() {
  collective([&]() { impl_->pg->barrier()->wait(); });
}

}  // namespace f16race::dist
