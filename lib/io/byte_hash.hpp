#pragma once
// FNV-1a, 64 bit, over bytes: a cheap fingerprint of a file or a tensor that stays the same
// across builds and machines (std::hash promises neither), for "is this the same input?" checks.
#include <cstddef>
#include <cstdint>
#include <string_view>

namespace f16race::io {

inline constexpr std::uint64_t kFnv1aOffset = 1469598103934665603ULL;

// Continues hash `h` over `n` bytes at `data`; start from kFnv1aOffset.
inline std::uint64_t fnv1a(const void* data, std::size_t n, std::uint64_t h = kFnv1aOffset) {
  const auto* p = static_cast<const unsigned char*>(data);
  for (std::size_t i = 0; i < n; ++i) h = (h ^ p[i]) * 1099511628211ULL;
  return h;
}

inline std::uint64_t fnv1a(std::string_view bytes, std::uint64_t h = kFnv1aOffset) {
  return fnv1a(bytes.data(), bytes.size(), h);
}

}  // namespace f16race::io
