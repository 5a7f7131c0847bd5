#pragma once
// The few TCP socket calls the group's stores need (POSIX), each with the error named in one
// line: listen on a chosen address, connect with a deadline, send and receive whole messages.
#include <chrono>
#include <string>

namespace f16race::dist {

using SteadyClock = std::chrono::steady_clock;

// A file descriptor closed when it goes out of scope.
class Fd {
 public:
  explicit Fd(int fd = -1) : fd_(fd) {}
  ~Fd() { reset(); }
  Fd(Fd&& other) noexcept : fd_(other.release()) {}
  Fd& operator=(Fd&& other) noexcept;
  Fd(const Fd&) = delete;
  Fd& operator=(const Fd&) = delete;
  int get() const { return fd_; }
  explicit operator bool() const { return fd_ >= 0; }
  void reset(int fd = -1);
  int release();

 private:
  int fd_;
};

// A non-blocking socket listening on `address` (numeric, or a name this host resolves) and `port`
// (0: a free one). Throws std::runtime_error naming the address and the system's reason.
Fd listen_tcp(const std::string& address, int port);

// Connects to host:port, trying again while nothing listens there yet (rank 0 may start last),
// until `deadline`. The socket is blocking, with TCP_NODELAY (one small request per reply).
// Throws std::runtime_error with the last reason.
Fd connect_tcp(const std::string& host, int port, SteadyClock::time_point deadline);

// A socket's peer ("127.0.0.1:54321", "[::1]:54321") and its own address.
std::string peer_name(int fd);
std::string local_name(int fd);
int local_port(int fd);

// Sends every byte (blocking socket); throws std::runtime_error when the peer is gone.
void send_all(int fd, const std::string& bytes);

// Reads exactly `n` bytes before `deadline` (SteadyClock::time_point::max(): no limit); throws
// std::runtime_error on a closed connection, an error or the deadline.
std::string recv_exact(int fd, std::size_t n, SteadyClock::time_point deadline);

}  // namespace f16race::dist
