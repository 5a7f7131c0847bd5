#include "io/json_text.hpp"

#include <cstdio>

namespace f16race::io {

std::string json_string(const std::string& s) {
  std::string o = "\"";
  o.reserve(s.size() + 2);
  for (const char c : s) {
    switch (c) {
      case '"': o += "\\\""; break;
      case '\\': o += "\\\\"; break;
      case '\n': o += "\\n"; break;
      case '\r': o += "\\r"; break;
      case '\t': o += "\\t"; break;
      case '\b': o += "\\b"; break;
      case '\f': o += "\\f"; break;
      default:
        if (static_cast<unsigned char>(c) < 0x20) {
          char u[8];
          std::snprintf(u, sizeof u, "\\u%04x", static_cast<unsigned>(static_cast<unsigned char>(c)));
          o += u;
        } else {
          o += c;
        }
    }
  }
  return o + "\"";
}

}  // namespace f16race::io
