#pragma once
// The group's shared token: the secret every rank presents to rank 0's stores before they answer
// it (docs/distributed.md, "What is protected"). It comes from the environment or a file, never
// the command line (which every user of the host can read in /proc).
#include <string>

namespace f16race::dist {

// Shortest and longest token accepted: a short one is guessable, a huge one is a mistake.
constexpr std::size_t kMinTokenChars = 16;
constexpr std::size_t kMaxTokenChars = 1024;

// F16RACE_GROUP_TOKEN, or the contents of the file F16RACE_GROUP_TOKEN_FILE (one trailing newline
// dropped); "" when neither is set. Throws io::InputError naming the variable and the fix when
// both are set, the file cannot be read, or the token is too short, too long or has a NUL byte.
std::string group_token_from_environment();

// A fresh token for the ranks `launch` starts: 32 bytes of /dev/urandom as 64 hex digits.
std::string random_group_token();

// Whether `a` equals `b`, in a time that depends on their lengths only, not on where they first
// differ (a stranger timing the answers learns nothing about the token's bytes).
bool tokens_equal(const std::string& a, const std::string& b);

}  // namespace f16race::dist
