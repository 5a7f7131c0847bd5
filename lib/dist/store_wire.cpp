#include "dist/store_wire.hpp"

namespace f16race::dist::wire {

namespace {

void put_le(std::string& out, std::uint64_t v, int bytes) {
  for (int i = 0; i < bytes; ++i) out.push_back(static_cast<char>((v >> (8 * i)) & 0xFF));
}

std::uint64_t get_le(const char* p, int bytes) {
  std::uint64_t v = 0;
  for (int i = 0; i < bytes; ++i) v |= static_cast<std::uint64_t>(static_cast<unsigned char>(p[i])) << (8 * i);
  return v;
}

}  // namespace

Writer& Writer::u8(std::uint8_t v) {
  payload_.push_back(static_cast<char>(v));
  return *this;
}

Writer& Writer::i64(std::int64_t v) {
  put_le(payload_, static_cast<std::uint64_t>(v), 8);
  return *this;
}

Writer& Writer::blob(const std::string& bytes) {
  put_le(payload_, bytes.size(), 4);
  payload_ += bytes;
  return *this;
}

Writer& Writer::raw(const std::string& bytes) {
  payload_ += bytes;
  return *this;
}

std::string Writer::frame() const {
  std::string out;
  out.reserve(kFrameHeaderBytes + payload_.size());
  put_le(out, payload_.size(), 4);
  out += payload_;
  return out;
}

const char* Reader::take(std::size_t n) {
  if (payload_.size() - at_ < n) throw Malformed("a field runs past the end of its message");
  const char* p = payload_.data() + at_;
  at_ += n;
  return p;
}

std::uint8_t Reader::u8() { return static_cast<std::uint8_t>(*take(1)); }

std::int64_t Reader::i64() { return static_cast<std::int64_t>(get_le(take(8), 8)); }

std::string Reader::blob() {
  const auto n = static_cast<std::size_t>(get_le(take(4), 4));
  return std::string(take(n), n);
}

std::optional<std::uint32_t> frame_length(const std::string& buffer) {
  if (buffer.size() < kFrameHeaderBytes) return std::nullopt;
  return static_cast<std::uint32_t>(get_le(buffer.data(), 4));
}

}  // namespace f16race::dist::wire
