#include "dist/token_store_server.hpp"

#include <fcntl.h>
#include <netinet/in.h>
#include <netinet/tcp.h>
#include <poll.h>
#include <sys/socket.h>
#include <unistd.h>

#include <algorithm>
#include <cerrno>
#include <cstdio>
#include <cstdlib>
#include <cstring>
#include <list>
#include <optional>
#include <unordered_map>
#include <vector>

#include "dist/group_token.hpp"
#include "dist/store_wire.hpp"
#include "dist/tcp_socket.hpp"

namespace f16race::dist {

// Anonymous: this file is left out of the unity batch (CMakeLists.txt), so these names stay its
// own, and GCC accepts Loop (external linkage) holding their types only in a file of its own.
namespace {

using Clock = SteadyClock;
using wire::Op;
using wire::Status;

constexpr std::size_t kReadChunkBytes = 64 * 1024;
// Out of file descriptors: stop accepting this long rather than spin on the listening socket.
constexpr auto kAcceptPause = std::chrono::milliseconds(100);
constexpr int kMaxPollMs = 1000;
constexpr int kMaxAcceptsPerRound = 64;  // then serve the others before accepting more

// A get or wait whose keys have not all arrived: answered when they do or at its deadline.
struct Parked {
  Op op;
  std::vector<std::string> keys;
  Clock::time_point deadline;
};

struct Connection {
  Fd fd;  // closed (-1) once dropped; removed at the end of the round
  std::string peer;
  bool authenticated = false;
  Clock::time_point greeting_deadline;
  std::string in;   // received, not yet handled
  std::string out;  // to send
  std::optional<Parked> parked;
};

Clock::time_point deadline_after_ms(std::int64_t timeout_ms) {
  return timeout_ms <= 0 ? Clock::time_point::max() : Clock::now() + std::chrono::milliseconds(timeout_ms);
}

std::string no_token(const std::string& detail) { return "no valid group token (" + detail + ")"; }

void end_of(const wire::Reader& r) {
  if (!r.done()) throw wire::Malformed("bytes after the last field");
}

// Names each dropped connection in one line, the first kNamedPerWindow of each window; the rest
// are counted and summed up in one line when the window ends, so a flood cannot flood stderr.
class DropLog {
 public:
  DropLog(std::function<void(const std::string&)> log, std::string store_name)
      : log_(std::move(log)), store_name_(std::move(store_name)), window_end_(Clock::now() + kWindow) {}

  void dropped(const std::string& peer, const std::string& reason) {
    tick(Clock::now());
    if (named_ >= kNamedPerWindow) {
      ++unnamed_;
      return;
    }
    ++named_;
    emit("dropped a connection from " + peer + " to " + store_name_ + ": " + reason);
  }

  void tick(Clock::time_point now) {
    if (now < window_end_) return;
    if (unnamed_ > 0)
      emit("dropped " + std::to_string(unnamed_) + " more connections to " + store_name_ + " in the last " +
           std::to_string(kWindow.count()) + " s (not each named)");
    named_ = unnamed_ = 0;
    window_end_ = now + kWindow;
  }

  // When tick() has a summary to write (max(): none pending).
  Clock::time_point due() const { return unnamed_ > 0 ? window_end_ : Clock::time_point::max(); }

 private:
  static constexpr int kNamedPerWindow = 20;
  static constexpr std::chrono::seconds kWindow{10};
  void emit(const std::string& line) {
    if (log_) log_(line);
  }
  std::function<void(const std::string&)> log_;
  std::string store_name_;
  Clock::time_point window_end_;
  int named_ = 0;
  long unnamed_ = 0;
};

}  // namespace

class TokenStoreServer::Loop {
 public:
  explicit Loop(StoreServerOptions options);
  void run();
  void stop();
  int port() const { return local_port(listener_.get()); }
  std::string name() const { return dist::local_name(listener_.get()); }

 private:
  void serve_round(std::vector<pollfd>& fds, std::vector<Connection*>& polled);
  void accept_new();
  bool drop_oldest_greeting();
  void receive(Connection& c);
  void handle_greeting(Connection& c);
  void handle_requests(Connection& c);
  void execute(Connection& c, wire::Reader& r);
  void execute_add(Connection& c, wire::Reader& r);
  void execute_compare_set(Connection& c, wire::Reader& r);
  bool try_answer(Connection& c);
  void settle();
  void expire(Clock::time_point now);
  void reply(Connection& c, const std::string& frame);
  void flush(Connection& c);
  void drop(Connection& c, const std::string& reason);
  static void close(Connection& c);
  int poll_timeout_ms(Clock::time_point now) const;

  StoreServerOptions opt_;
  Fd listener_, wake_read_, wake_write_;
  std::list<Connection> conns_;  // stable addresses while a round walks them; oldest first
  std::unordered_map<std::string, std::string> data_;
  bool data_changed_ = false;  // a key was set: parked requests may be answerable
  DropLog drops_;
  Clock::time_point accept_paused_until_{};
};

TokenStoreServer::Loop::Loop(StoreServerOptions options)
    : opt_(std::move(options)), drops_(opt_.log, opt_.name) {
  listener_ = listen_tcp(opt_.bind_address, opt_.port);
  int pipe_fds[2];
  if (::pipe2(pipe_fds, O_NONBLOCK | O_CLOEXEC) != 0)
    throw std::runtime_error(std::string("cannot create the store's wake-up pipe: ") + std::strerror(errno));
  wake_read_.reset(pipe_fds[0]);
  wake_write_.reset(pipe_fds[1]);
}

void TokenStoreServer::Loop::stop() {
  const char byte = 1;
  [[maybe_unused]] const ssize_t n = ::write(wake_write_.get(), &byte, 1);
}

void TokenStoreServer::Loop::run() {
  std::vector<pollfd> fds;
  std::vector<Connection*> polled;
  for (;;) {
    const auto now = Clock::now();
    fds.clear();
    polled.clear();
    fds.push_back({wake_read_.get(), POLLIN, 0});
    fds.push_back({now >= accept_paused_until_ ? listener_.get() : -1, POLLIN, 0});  // -1: poll skips it
    for (auto& c : conns_) {
      fds.push_back({c.fd.get(), static_cast<short>(POLLIN | (c.out.empty() ? 0 : POLLOUT)), 0});
      polled.push_back(&c);
    }
    const int ready = ::poll(fds.data(), fds.size(), poll_timeout_ms(now));
    if (ready < 0 && errno != EINTR) {
      if (opt_.log) opt_.log(opt_.name + " stopped serving: poll failed: " + std::strerror(errno));
      return;
    }
    if (fds[0].revents != 0) return;  // stop()
    serve_round(fds, polled);
  }
}

void TokenStoreServer::Loop::serve_round(std::vector<pollfd>& fds, std::vector<Connection*>& polled) {
  if (fds[1].revents & POLLIN) accept_new();
  for (std::size_t i = 0; i < polled.size(); ++i) {
    Connection& c = *polled[i];
    const short events = fds[i + 2].revents;
    if (!c.fd || events == 0) continue;
    try {
      if (events & POLLOUT) flush(c);
      if (c.fd && (events & (POLLIN | POLLHUP | POLLERR))) receive(c);
    } catch (const std::exception& e) {  // e.g. no memory for its message: this connection alone ends
      drop(c, std::string("an error while serving it: ") + e.what());
    }
  }
  settle();
  expire(Clock::now());
  settle();
  drops_.tick(Clock::now());
  conns_.remove_if([](const Connection& c) { return !c.fd; });
}

int TokenStoreServer::Loop::poll_timeout_ms(Clock::time_point now) const {
  auto next = std::min(drops_.due(), now + std::chrono::milliseconds(kMaxPollMs));
  if (accept_paused_until_ > now) next = std::min(next, accept_paused_until_);
  for (const auto& c : conns_) {
    if (!c.authenticated) next = std::min(next, c.greeting_deadline);
    if (c.parked) next = std::min(next, c.parked->deadline);
  }
  if (data_changed_ || next <= now) return 0;
  // Rounded up: waking a millisecond early would spin until the deadline.
  return static_cast<int>(std::chrono::duration_cast<std::chrono::milliseconds>(next - now).count()) + 1;
}

void TokenStoreServer::Loop::accept_new() {
  for (int n = 0; n < kMaxAcceptsPerRound; ++n) {
    Fd fd(::accept4(listener_.get(), nullptr, nullptr, SOCK_NONBLOCK | SOCK_CLOEXEC));
    if (!fd) {
      if (errno == EINTR || errno == ECONNABORTED) continue;
      if ((errno == EMFILE || errno == ENFILE) && drop_oldest_greeting()) continue;
      if (errno == EMFILE || errno == ENFILE) accept_paused_until_ = Clock::now() + kAcceptPause;
      return;  // EAGAIN: none left
    }
    const int one = 1;
    ::setsockopt(fd.get(), IPPROTO_TCP, TCP_NODELAY, &one, sizeof one);
    const auto waiting = static_cast<std::size_t>(
        std::count_if(conns_.begin(), conns_.end(), [](const Connection& c) { return c.fd && !c.authenticated; }));
    if (waiting >= opt_.max_greeting_connections) drop_oldest_greeting();
    Connection c;
    c.peer = peer_name(fd.get());
    c.fd = std::move(fd);
    c.greeting_deadline = Clock::now() + opt_.greeting_timeout;
    conns_.push_back(std::move(c));
  }
}

bool TokenStoreServer::Loop::drop_oldest_greeting() {
  for (auto& c : conns_)
    if (c.fd && !c.authenticated) {
      drop(c, no_token("none yet while " + std::to_string(opt_.max_greeting_connections) +
                       " connections waited to present one"));
      return true;
    }
  return false;
}

void TokenStoreServer::Loop::receive(Connection& c) {
  char buffer[kReadChunkBytes];
  const ssize_t n = ::recv(c.fd.get(), buffer, sizeof buffer, 0);
  if (n < 0 && (errno == EAGAIN || errno == EWOULDBLOCK || errno == EINTR)) return;
  if (n <= 0) {  // closed or reset: a member leaving is no news, a stranger is named
    if (c.authenticated)
      close(c);
    else
      drop(c, no_token(c.in.empty() ? "closed before sending one" : "closed in the middle of its greeting"));
    return;
  }
  c.in.append(buffer, static_cast<std::size_t>(n));
  if (!c.authenticated) handle_greeting(c);
  if (c.fd && c.authenticated) handle_requests(c);
}

void TokenStoreServer::Loop::handle_greeting(Connection& c) {
  const auto length = wire::frame_length(c.in);
  if (!length) return;
  const std::string garbage = no_token("bytes that are not an f16race store greeting");
  if (*length < wire::kGreetingMagicBytes || *length > wire::kMaxGreetingBytes) return drop(c, garbage);
  // The greeting's first bytes are checked as they come: garbage is dropped at once.
  const std::size_t have = std::min(c.in.size() - wire::kFrameHeaderBytes, wire::kGreetingMagicBytes);
  if (c.in.compare(wire::kFrameHeaderBytes, have, wire::kGreeting, have) != 0) return drop(c, garbage);
  if (c.in.size() < wire::kFrameHeaderBytes + *length) return;
  const std::size_t token_at = wire::kFrameHeaderBytes + wire::kGreetingMagicBytes;
  const std::string token = c.in.substr(token_at, *length - wire::kGreetingMagicBytes);
  c.in.erase(0, wire::kFrameHeaderBytes + *length);
  if (!tokens_equal(opt_.token, token)) {
    // Told why (a rank started with another token says so), best effort: the stranger may not read.
    const std::string refused = wire::Writer().u8(static_cast<std::uint8_t>(Status::refused)).frame();
    [[maybe_unused]] const ssize_t n = ::send(c.fd.get(), refused.data(), refused.size(), MSG_NOSIGNAL | MSG_DONTWAIT);
    return drop(c, no_token("a wrong token"));
  }
  c.authenticated = true;
  reply(c, wire::Writer().u8(static_cast<std::uint8_t>(Status::ok)).frame());
}

void TokenStoreServer::Loop::handle_requests(Connection& c) {
  // One request at a time, in order: a parked get holds back the requests behind it.
  while (c.fd && !c.parked) {
    const auto length = wire::frame_length(c.in);
    if (!length) return;
    if (*length == 0 || *length > wire::kMaxFrameBytes)
      return drop(c, "a malformed request (a message of " + std::to_string(*length) + " bytes)");
    if (c.in.size() < wire::kFrameHeaderBytes + *length) return;
    wire::Reader r(c.in.substr(wire::kFrameHeaderBytes, *length));
    c.in.erase(0, wire::kFrameHeaderBytes + *length);
    try {
      execute(c, r);
    } catch (const wire::Malformed& e) {
      return drop(c, std::string("a malformed request (") + e.what() + ")");
    }
  }
}

void TokenStoreServer::Loop::execute(Connection& c, wire::Reader& r) {
  const auto ok = [] { return wire::Writer().u8(static_cast<std::uint8_t>(Status::ok)); };
  const auto op = static_cast<Op>(r.u8());
  switch (op) {
    case Op::set: {
      std::string key = r.blob();
      std::string value = r.blob();
      end_of(r);
      data_[std::move(key)] = std::move(value);
      data_changed_ = true;
      return reply(c, ok().frame());
    }
    case Op::get:
    case Op::wait: {
      Parked p{op, {}, {}};
      const std::int64_t n_keys = op == Op::get ? 1 : r.i64();
      if (n_keys < 0) throw wire::Malformed("a negative key count");
      for (std::int64_t k = 0; k < n_keys; ++k) p.keys.push_back(r.blob());
      p.deadline = deadline_after_ms(r.i64());
      end_of(r);
      c.parked = std::move(p);
      try_answer(c);
      return;
    }
    case Op::add: return execute_add(c, r);
    case Op::compare_set: return execute_compare_set(c, r);
    case Op::delete_key: {
      const std::string key = r.blob();
      end_of(r);
      return reply(c, ok().u8(data_.erase(key) > 0 ? 1 : 0).frame());
    }
    case Op::check: {
      bool all = true;
      const std::int64_t n_keys = r.i64();
      for (std::int64_t k = 0; k < n_keys; ++k) all = data_.count(r.blob()) > 0 && all;
      end_of(r);
      return reply(c, ok().u8(all ? 1 : 0).frame());
    }
    case Op::num_keys:
      end_of(r);
      return reply(c, ok().i64(static_cast<std::int64_t>(data_.size())).frame());
  }
  throw wire::Malformed("an unknown request " + std::to_string(static_cast<int>(op)));
}

void TokenStoreServer::Loop::execute_add(Connection& c, wire::Reader& r) {
  // Counters are kept as decimal text, as c10d's TCPStore keeps them (get() reads them so).
  const std::string key = r.blob();
  const std::int64_t delta = r.i64();
  end_of(r);
  std::int64_t value = 0;
  const auto it = data_.find(key);
  if (it != data_.end()) {
    char* end = nullptr;
    errno = 0;
    value = std::strtoll(it->second.c_str(), &end, 10);
    if (it->second.empty() || errno != 0 || *end != '\0')
      return reply(c, wire::Writer().u8(static_cast<std::uint8_t>(Status::error)).blob("key '" + key + "' holds no integer").frame());
  }
  if (__builtin_add_overflow(value, delta, &value))
    return reply(c, wire::Writer().u8(static_cast<std::uint8_t>(Status::error)).blob("adding to key '" + key + "' overflows").frame());
  data_[key] = std::to_string(value);
  data_changed_ = true;
  reply(c, wire::Writer().u8(static_cast<std::uint8_t>(Status::ok)).i64(value).frame());
}

void TokenStoreServer::Loop::execute_compare_set(Connection& c, wire::Reader& r) {
  // TCPStore's rule: a missing key is created only when `expected` is empty; the answer is the
  // key's value afterwards (for a missing key left alone: `expected`).
  const std::string key = r.blob();
  const std::string expected = r.blob();
  std::string desired = r.blob();
  end_of(r);
  std::string answer;
  const auto it = data_.find(key);
  if (it == data_.end()) {
    answer = expected.empty() ? desired : expected;
    if (expected.empty()) data_[key] = std::move(desired), data_changed_ = true;
  } else {
    if (it->second == expected) it->second = std::move(desired), data_changed_ = true;
    answer = it->second;
  }
  reply(c, wire::Writer().u8(static_cast<std::uint8_t>(Status::ok)).blob(answer).frame());
}

bool TokenStoreServer::Loop::try_answer(Connection& c) {
  const Parked& p = *c.parked;
  for (const auto& key : p.keys)
    if (data_.count(key) == 0) return false;
  wire::Writer w;
  w.u8(static_cast<std::uint8_t>(Status::ok));
  if (p.op == Op::get) w.blob(data_[p.keys.front()]);
  c.parked.reset();
  reply(c, w.frame());
  return true;
}

void TokenStoreServer::Loop::settle() {
  // Answering one may let its connection's next request set a key another waits for.
  while (data_changed_) {
    data_changed_ = false;
    for (auto& c : conns_)
      if (c.fd && c.parked && try_answer(c)) handle_requests(c);
  }
}

void TokenStoreServer::Loop::expire(Clock::time_point now) {
  for (auto& c : conns_) {
    if (!c.fd) continue;
    if (!c.authenticated && now >= c.greeting_deadline) {
      const auto waited_s = std::chrono::duration_cast<std::chrono::duration<double>>(opt_.greeting_timeout).count();
      char detail[64];
      std::snprintf(detail, sizeof detail, "none presented within %g s", waited_s);
      drop(c, no_token(detail));
    } else if (c.parked && now >= c.parked->deadline) {
      c.parked.reset();
      reply(c, wire::Writer().u8(static_cast<std::uint8_t>(Status::timeout)).frame());
      handle_requests(c);
    }
  }
}

void TokenStoreServer::Loop::reply(Connection& c, const std::string& frame) {
  c.out += frame;
  flush(c);
}

void TokenStoreServer::Loop::flush(Connection& c) {
  while (c.fd && !c.out.empty()) {
    const ssize_t n = ::send(c.fd.get(), c.out.data(), c.out.size(), MSG_NOSIGNAL | MSG_DONTWAIT);
    if (n < 0 && errno == EINTR) continue;
    if (n < 0 && (errno == EAGAIN || errno == EWOULDBLOCK)) return;  // poll says when it can take more
    if (n <= 0) return close(c);  // the peer is gone
    c.out.erase(0, static_cast<std::size_t>(n));
  }
}

void TokenStoreServer::Loop::drop(Connection& c, const std::string& reason) {
  drops_.dropped(c.peer, reason);
  close(c);
}

void TokenStoreServer::Loop::close(Connection& c) {
  c.fd.reset();
  c.parked.reset();
  c.in.clear();
  c.out.clear();
}

TokenStoreServer::TokenStoreServer(StoreServerOptions options)
    : loop_(std::make_unique<Loop>(std::move(options))) {
  Loop* loop = loop_.get();
  thread_ = std::thread([loop]() { loop->run(); });
}

TokenStoreServer::~TokenStoreServer() {
  loop_->stop();
  thread_.join();
}

int TokenStoreServer::port() const { return loop_->port(); }

std::string TokenStoreServer::local_name() const { return loop_->name(); }

}  // namespace f16race::dist
