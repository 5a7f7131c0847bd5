#include "dist/token_store.hpp"

#include <algorithm>

#include "dist/store_wire.hpp"

namespace f16race::dist {

namespace {

using wire::Op;
using wire::Status;

// Beyond the time the server may hold a request: a store that still has not answered is gone.
constexpr std::chrono::milliseconds kReplyGrace{5000};
// The greeting's answer comes at once from a live server; a slow network gets this much.
constexpr std::chrono::milliseconds kMinGreetingWait{5000};

std::string bytes_of(const std::vector<std::uint8_t>& v) { return std::string(v.begin(), v.end()); }
std::vector<std::uint8_t> vector_of(const std::string& s) { return std::vector<std::uint8_t>(s.begin(), s.end()); }

std::string quoted_keys(const std::vector<std::string>& keys) {
  std::string out;
  for (const auto& k : keys) out += (out.empty() ? "'" : ", '") + k + "'";
  return out;
}

SteadyClock::time_point deadline_after(std::chrono::milliseconds wait) {
  if (wait <= std::chrono::milliseconds::zero()) return SteadyClock::time_point::max();  // c10d's kNoTimeout
  return SteadyClock::now() + wait;
}

// One frame's payload from a blocking socket, by `deadline`.
std::string receive_frame(int fd, SteadyClock::time_point deadline) {
  const auto length = wire::frame_length(recv_exact(fd, wire::kFrameHeaderBytes, deadline));
  if (*length == 0 || *length > wire::kMaxFrameBytes)
    throw std::runtime_error("a reply of " + std::to_string(*length) + " bytes is not the store's");
  return recv_exact(fd, *length, deadline);
}

}  // namespace

TokenStore::TokenStore(const std::string& host, int port, const std::string& token, std::chrono::milliseconds timeout)
    : c10d::Store(timeout), where_(host + ":" + std::to_string(port)) {
  fd_ = connect_tcp(host, port, SteadyClock::now() + timeout);
  std::string reply;
  try {
    send_all(fd_.get(), wire::Writer().raw(wire::kGreeting).raw(token).frame());
    reply = receive_frame(fd_.get(), SteadyClock::now() + std::max(timeout, kMinGreetingWait));
  } catch (const std::runtime_error& e) {
    throw std::runtime_error("the store at " + where_ + " did not answer this rank's greeting (" + e.what() +
                             "): is it an f16race group's store, of this version?");
  }
  if (reply.size() == 1 && static_cast<Status>(reply[0]) == Status::refused)
    throw TokenRefused("the store at " + where_ + " refused this rank's group token");
  if (reply.size() != 1 || static_cast<Status>(reply[0]) != Status::ok)
    throw std::runtime_error("the store at " + where_ + " answered this rank's greeting with bytes that are not a store's");
}

TokenStore::~TokenStore() = default;

std::string TokenStore::call(const std::string& frame, std::chrono::milliseconds server_wait, const std::string& what) {
  std::lock_guard<std::mutex> lock(mutex_);
  if (!fd_) throw std::runtime_error("the store at " + where_ + ": " + what + ": the connection was lost earlier");
  std::string reply;
  try {
    send_all(fd_.get(), frame);
    const auto wait = server_wait <= std::chrono::milliseconds::zero() ? server_wait : server_wait + kReplyGrace;
    reply = receive_frame(fd_.get(), deadline_after(wait));
  } catch (const std::runtime_error& e) {
    fd_.reset();  // a reply may still be on its way: this connection's order is lost
    throw std::runtime_error("the store at " + where_ + ": " + what + ": " + e.what());
  }
  wire::Reader r(reply);
  const auto status = static_cast<Status>(r.u8());
  if (status == Status::ok) return reply.substr(1);
  if (status == Status::timeout)
    throw std::runtime_error("the store at " + where_ + ": " + what + ": timed out after " +
                             std::to_string(server_wait.count()) + " ms");
  const std::string why = status == Status::error ? r.blob() : "an unknown status";
  throw std::runtime_error("the store at " + where_ + ": " + what + ": " + why);
}

void TokenStore::set(const std::string& key, const std::vector<std::uint8_t>& value) {
  call(wire::Writer().u8(static_cast<std::uint8_t>(Op::set)).blob(key).blob(bytes_of(value)).frame(), timeout_,
       "set '" + key + "'");
}

std::vector<std::uint8_t> TokenStore::compareSet(const std::string& key, const std::vector<std::uint8_t>& expected,
                                                 const std::vector<std::uint8_t>& desired) {
  const std::string frame = wire::Writer()
                                .u8(static_cast<std::uint8_t>(Op::compare_set))
                                .blob(key)
                                .blob(bytes_of(expected))
                                .blob(bytes_of(desired))
                                .frame();
  wire::Reader r(call(frame, timeout_, "compare-and-set '" + key + "'"));
  return vector_of(r.blob());
}

std::vector<std::uint8_t> TokenStore::get(const std::string& key) {
  const std::string frame =
      wire::Writer().u8(static_cast<std::uint8_t>(Op::get)).blob(key).i64(timeout_.count()).frame();
  wire::Reader r(call(frame, timeout_, "get '" + key + "'"));
  return vector_of(r.blob());
}

std::int64_t TokenStore::add(const std::string& key, std::int64_t value) {
  const std::string frame = wire::Writer().u8(static_cast<std::uint8_t>(Op::add)).blob(key).i64(value).frame();
  wire::Reader r(call(frame, timeout_, "add to '" + key + "'"));
  return r.i64();
}

bool TokenStore::deleteKey(const std::string& key) {
  wire::Reader r(call(wire::Writer().u8(static_cast<std::uint8_t>(Op::delete_key)).blob(key).frame(), timeout_,
                      "delete '" + key + "'"));
  return r.u8() != 0;
}

bool TokenStore::check(const std::vector<std::string>& keys) {
  wire::Writer w;
  w.u8(static_cast<std::uint8_t>(Op::check)).i64(static_cast<std::int64_t>(keys.size()));
  for (const auto& k : keys) w.blob(k);
  wire::Reader r(call(w.frame(), timeout_, "check " + quoted_keys(keys)));
  return r.u8() != 0;
}

std::int64_t TokenStore::getNumKeys() {
  wire::Reader r(call(wire::Writer().u8(static_cast<std::uint8_t>(Op::num_keys)).frame(), timeout_, "count the keys"));
  return r.i64();
}

void TokenStore::wait(const std::vector<std::string>& keys) { wait(keys, timeout_); }

void TokenStore::wait(const std::vector<std::string>& keys, const std::chrono::milliseconds& timeout) {
  wire::Writer w;
  w.u8(static_cast<std::uint8_t>(Op::wait)).i64(static_cast<std::int64_t>(keys.size()));
  for (const auto& k : keys) w.blob(k);
  w.i64(timeout.count());
  call(w.frame(), timeout, "wait for " + quoted_keys(keys));
}

}  // namespace f16race::dist
