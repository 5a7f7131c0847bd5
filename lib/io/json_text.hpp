#pragma once

#include <string>

namespace f16race::io {

// `s` as a JSON string literal, quotes included (RFC 8259 section 7): '"' and '\' escaped, control
// characters as \n, \t, ... or \u00XX; other bytes (UTF-8 included) pass through. The bench
// lines, the tournament's JSON and anything else that prints a path or a CPU name use it, so a
// config path with a quote or a tab still gives a line `json.loads` reads.
std::string json_string(const std::string& s);

}  // namespace f16race::io
