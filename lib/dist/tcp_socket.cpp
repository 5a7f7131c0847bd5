#include "dist/tcp_socket.hpp"

#include <arpa/inet.h>
#include <fcntl.h>
#include <netdb.h>
#include <netinet/in.h>
#include <netinet/tcp.h>
#include <poll.h>
#include <sys/socket.h>
#include <unistd.h>

#include <algorithm>
#include <cerrno>
#include <cstring>
#include <memory>
#include <stdexcept>
#include <thread>

namespace f16race::dist {

namespace {

using AddrList = std::unique_ptr<addrinfo, decltype(&freeaddrinfo)>;

// The addresses of host:port (passive: for bind). Throws with getaddrinfo's reason.
AddrList resolve(const std::string& host, int port, bool passive, int* error_out = nullptr) {
  addrinfo hints{};
  hints.ai_family = AF_UNSPEC;
  hints.ai_socktype = SOCK_STREAM;
  hints.ai_flags = AI_NUMERICSERV | (passive ? AI_PASSIVE : 0);
  addrinfo* list = nullptr;
  const int rc = ::getaddrinfo(host.c_str(), std::to_string(port).c_str(), &hints, &list);
  if (error_out) *error_out = rc;
  if (rc != 0) throw std::runtime_error("cannot resolve '" + host + "': " + ::gai_strerror(rc));
  return AddrList(list, &freeaddrinfo);
}

std::string name_of(const sockaddr_storage& a) {
  char text[INET6_ADDRSTRLEN] = "?";
  if (a.ss_family == AF_INET) {
    const auto& v4 = reinterpret_cast<const sockaddr_in&>(a);
    ::inet_ntop(AF_INET, &v4.sin_addr, text, sizeof text);
    return std::string(text) + ":" + std::to_string(ntohs(v4.sin_port));
  }
  if (a.ss_family == AF_INET6) {
    const auto& v6 = reinterpret_cast<const sockaddr_in6&>(a);
    ::inet_ntop(AF_INET6, &v6.sin6_addr, text, sizeof text);
    return "[" + std::string(text) + "]:" + std::to_string(ntohs(v6.sin6_port));
  }
  return "an unknown address";
}

int millis_until(SteadyClock::time_point deadline) {
  if (deadline == SteadyClock::time_point::max()) return -1;
  const auto left = std::chrono::duration_cast<std::chrono::milliseconds>(deadline - SteadyClock::now()).count();
  return static_cast<int>(std::clamp<long long>(left, 0, 1 << 30));
}

// One non-blocking connect to `ai`, waited for until `deadline`: the socket, or "" + `why`.
Fd try_connect(const addrinfo& ai, SteadyClock::time_point deadline, std::string& why) {
  Fd fd(::socket(ai.ai_family, SOCK_STREAM | SOCK_NONBLOCK | SOCK_CLOEXEC, 0));
  if (!fd) {
    why = std::strerror(errno);
    return Fd();
  }
  if (::connect(fd.get(), ai.ai_addr, ai.ai_addrlen) != 0) {
    if (errno != EINPROGRESS) {
      why = std::strerror(errno);
      return Fd();
    }
    pollfd p{fd.get(), POLLOUT, 0};
    if (::poll(&p, 1, millis_until(deadline)) <= 0) {
      why = "no answer before the deadline";
      return Fd();
    }
    int err = 0;
    socklen_t len = sizeof err;
    ::getsockopt(fd.get(), SOL_SOCKET, SO_ERROR, &err, &len);
    if (err != 0) {
      why = std::strerror(err);
      return Fd();
    }
  }
  ::fcntl(fd.get(), F_SETFL, ::fcntl(fd.get(), F_GETFL) & ~O_NONBLOCK);
  const int one = 1;
  ::setsockopt(fd.get(), IPPROTO_TCP, TCP_NODELAY, &one, sizeof one);
  return fd;
}

}  // namespace

Fd& Fd::operator=(Fd&& other) noexcept {
  if (this != &other) reset(other.release());
  return *this;
}

void Fd::reset(int fd) {
  if (fd_ >= 0) ::close(fd_);
  fd_ = fd;
}

int Fd::release() {
  const int fd = fd_;
  fd_ = -1;
  return fd;
}

Fd listen_tcp(const std::string& address, int port) {
  const AddrList list = resolve(address, port, true);
  std::string why = "no address";
  for (const addrinfo* ai = list.get(); ai; ai = ai->ai_next) {
    Fd fd(::socket(ai->ai_family, SOCK_STREAM | SOCK_NONBLOCK | SOCK_CLOEXEC, 0));
    if (!fd) {
      why = std::strerror(errno);
      continue;
    }
    // A port left in TIME_WAIT by the previous group's store must not block this one.
    const int one = 1;
    ::setsockopt(fd.get(), SOL_SOCKET, SO_REUSEADDR, &one, sizeof one);
    if (::bind(fd.get(), ai->ai_addr, ai->ai_addrlen) == 0 && ::listen(fd.get(), SOMAXCONN) == 0) return fd;
    why = std::strerror(errno);
  }
  throw std::runtime_error("cannot listen on " + address + ":" + std::to_string(port) + ": " + why);
}

Fd connect_tcp(const std::string& host, int port, SteadyClock::time_point deadline) {
  std::string why;
  for (;;) {
    int gai = 0;
    try {
      const AddrList list = resolve(host, port, false, &gai);
      for (const addrinfo* ai = list.get(); ai; ai = ai->ai_next) {
        Fd fd = try_connect(*ai, deadline, why);
        if (fd) return fd;
      }
    } catch (const std::runtime_error& e) {
      if (gai != EAI_AGAIN) throw;  // a name that does not exist will not start to
      why = e.what();
    }
    if (SteadyClock::now() >= deadline) break;
    std::this_thread::sleep_for(std::min<SteadyClock::duration>(std::chrono::milliseconds(100), deadline - SteadyClock::now()));
  }
  throw std::runtime_error("cannot connect to " + host + ":" + std::to_string(port) + ": " + why);
}

std::string peer_name(int fd) {
  sockaddr_storage a{};
  socklen_t len = sizeof a;
  if (::getpeername(fd, reinterpret_cast<sockaddr*>(&a), &len) != 0) return "an address already gone";
  return name_of(a);
}

std::string local_name(int fd) {
  sockaddr_storage a{};
  socklen_t len = sizeof a;
  if (::getsockname(fd, reinterpret_cast<sockaddr*>(&a), &len) != 0) return "?";
  return name_of(a);
}

int local_port(int fd) {
  sockaddr_storage a{};
  socklen_t len = sizeof a;
  if (::getsockname(fd, reinterpret_cast<sockaddr*>(&a), &len) != 0) return -1;
  if (a.ss_family == AF_INET) return ntohs(reinterpret_cast<const sockaddr_in&>(a).sin_port);
  if (a.ss_family == AF_INET6) return ntohs(reinterpret_cast<const sockaddr_in6&>(a).sin6_port);
  return -1;
}

void send_all(int fd, const std::string& bytes) {
  std::size_t sent = 0;
  while (sent < bytes.size()) {
    const ssize_t n = ::send(fd, bytes.data() + sent, bytes.size() - sent, MSG_NOSIGNAL);
    if (n < 0 && errno == EINTR) continue;
    if (n <= 0) throw std::runtime_error(std::string("send failed: ") + std::strerror(errno));
    sent += static_cast<std::size_t>(n);
  }
}

std::string recv_exact(int fd, std::size_t n, SteadyClock::time_point deadline) {
  std::string out(n, '\0');
  std::size_t got = 0;
  while (got < n) {
    pollfd p{fd, POLLIN, 0};
    const int ready = ::poll(&p, 1, millis_until(deadline));
    if (ready < 0 && errno == EINTR) continue;
    if (ready < 0) throw std::runtime_error(std::string("poll failed: ") + std::strerror(errno));
    if (ready == 0) throw std::runtime_error("no answer before the deadline");
    const ssize_t r = ::recv(fd, out.data() + got, n - got, 0);
    if (r < 0 && (errno == EINTR || errno == EAGAIN)) continue;
    if (r < 0) throw std::runtime_error(std::string("receive failed: ") + std::strerror(errno));
    if (r == 0) throw std::runtime_error("the connection was closed");
    got += static_cast<std::size_t>(r);
  }
  return out;
}

}  // namespace f16race::dist
