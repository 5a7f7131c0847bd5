#include "dist/group_token.hpp"

#include <cstdio>
#include <cstdlib>
#include <fstream>
#include <iterator>
#include <stdexcept>

#include "io/input_error.hpp"

namespace f16race::dist {

namespace {

constexpr const char* kTokenVar = "F16RACE_GROUP_TOKEN";
constexpr const char* kTokenFileVar = "F16RACE_GROUP_TOKEN_FILE";

std::string read_token_file(const std::string& path) {
  std::ifstream in(path, std::ios::binary);
  if (!in) throw io::InputError(std::string(kTokenFileVar) + "=" + path + ": cannot read it: give a readable file holding the group's token");
  // Read one byte past the limit so an oversized file is refused rather than cut.
  std::string token;
  char c = 0;
  while (token.size() <= kMaxTokenChars + 1 && in.get(c)) token.push_back(c);
  if (!token.empty() && token.back() == '\n') token.pop_back();
  if (!token.empty() && token.back() == '\r') token.pop_back();
  return token;
}

void check_token(const std::string& token, const std::string& source) {
  if (token.size() < kMinTokenChars || token.size() > kMaxTokenChars)
    throw io::InputError(source + " holds " + std::to_string(token.size()) + " characters: the group token needs " +
                         std::to_string(kMinTokenChars) + " to " + std::to_string(kMaxTokenChars) +
                         " (e.g. `head -c 32 /dev/urandom | od -An -tx1 | tr -d ' \\n'`)");
  if (token.find('\0') != std::string::npos) throw io::InputError(source + " holds a NUL byte: use a text token");
}

}  // namespace

std::string group_token_from_environment() {
  const char* value = std::getenv(kTokenVar);
  const char* file = std::getenv(kTokenFileVar);
  if (value && file)
    throw io::InputError(std::string("both ") + kTokenVar + " and " + kTokenFileVar + " are set: unset one of them");
  if (value) {
    const std::string token = value;
    check_token(token, kTokenVar);
    return token;
  }
  if (file) {
    const std::string token = read_token_file(file);
    check_token(token, std::string(kTokenFileVar) + "=" + file);
    return token;
  }
  return "";
}

std::string random_group_token() {
  std::ifstream in("/dev/urandom", std::ios::binary);
  unsigned char bytes[32] = {};
  if (!in.read(reinterpret_cast<char*>(bytes), sizeof bytes))
    throw std::runtime_error("cannot read /dev/urandom for the group's token");
  static const char* hex = "0123456789abcdef";
  std::string token;
  for (unsigned char b : bytes) {
    token.push_back(hex[b >> 4]);
    token.push_back(hex[b & 15]);
  }
  return token;
}

bool tokens_equal(const std::string& a, const std::string& b) {
  // Every byte of `b` is compared (against `a` cycled), so the loop's length is b's alone.
  unsigned diff = a.size() == b.size() ? 0u : 1u;
  if (a.empty()) return b.empty();
  for (std::size_t i = 0; i < b.size(); ++i)
    diff |= static_cast<unsigned char>(a[i % a.size()]) ^ static_cast<unsigned char>(b[i]);
  return diff == 0;
}

}  // namespace f16race::dist
