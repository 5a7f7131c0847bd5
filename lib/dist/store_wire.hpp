#pragma once
// The wire format between TokenStore (client) and TokenStoreServer: every message is a frame, a
// 4-byte little-endian payload length and the payload. The client's first frame is its greeting
// (kGreeting then the group token); the server answers it with a status byte. Each later frame is
// one request (an Op byte and its fields), answered by one reply (a Status byte and its fields),
// in order. Fields: u8, i64 (8 bytes little-endian), blob (u32 length + bytes).
#include <cstdint>
#include <optional>
#include <stdexcept>
#include <string>
#include <utility>

#include "dist/group_token.hpp"

namespace f16race::dist::wire {

// The first bytes of a greeting: anything else on a new connection is a stranger's.
constexpr char kGreeting[] = "f16race-store-v1";
constexpr std::size_t kGreetingMagicBytes = sizeof(kGreeting) - 1;
constexpr std::uint32_t kMaxGreetingBytes = static_cast<std::uint32_t>(kGreetingMagicBytes + kMaxTokenChars);
// The longest request or reply: far above what the rendezvous stores (fingerprints, addresses).
constexpr std::uint32_t kMaxFrameBytes = 64u << 20;
constexpr std::size_t kFrameHeaderBytes = 4;

enum class Op : std::uint8_t { set = 1, get, add, compare_set, delete_key, check, num_keys, wait };
enum class Status : std::uint8_t { ok = 0, timeout = 1, refused = 2, error = 3 };

// A frame that breaks the format (a field past its end, an unknown op).
struct Malformed : std::runtime_error {
  using std::runtime_error::runtime_error;
};

// Builds one frame field by field; frame() prefixes the length.
class Writer {
 public:
  Writer& u8(std::uint8_t v);
  Writer& i64(std::int64_t v);
  Writer& blob(const std::string& bytes);
  Writer& raw(const std::string& bytes);  // no length of its own (the greeting's parts)
  std::string frame() const;

 private:
  std::string payload_;
};

// Reads one frame's payload field by field; throws Malformed when a field runs past its end.
class Reader {
 public:
  explicit Reader(std::string payload) : payload_(std::move(payload)) {}
  std::uint8_t u8();
  std::int64_t i64();
  std::string blob();
  bool done() const { return at_ == payload_.size(); }

 private:
  const char* take(std::size_t n);
  std::string payload_;
  std::size_t at_ = 0;
};

// The payload length announced by the header at the start of `buffer`, once 4 bytes are there.
std::optional<std::uint32_t> frame_length(const std::string& buffer);

}  // namespace f16race::dist::wire
