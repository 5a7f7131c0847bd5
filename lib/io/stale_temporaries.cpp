#include "io/stale_temporaries.hpp"

#include <signal.h>

#include <algorithm>
#include <cctype>
#include <cerrno>
#include <filesystem>
#include <fstream>
#include <string>

namespace f16race::io {

namespace fs = std::filesystem;

namespace {

bool all_digits(const std::string& s) {
  return !s.empty() && std::all_of(s.begin(), s.end(), [](unsigned char c) { return std::isdigit(c) != 0; });
}

// The state letter of /proc/PID/stat ('Z' for a zombie), or 0 when it cannot be read.
char proc_state(long pid) {
  std::ifstream in("/proc/" + std::to_string(pid) + "/stat");
  std::string stat;
  std::getline(in, stat);
  // "PID (COMM) S ...": COMM may hold spaces and parentheses, so the state follows the last ')'.
  const auto close = stat.rfind(')');
  return close != std::string::npos && close + 2 < stat.size() ? stat[close + 2] : 0;
}

}  // namespace

long temporary_owner_pid(const std::string& name) {
  const auto at = name.rfind(".tmp.");
  if (at == std::string::npos || at == 0) return 0;
  std::string rest = name.substr(at + 5);
  const auto dot = rest.find('.');
  if (dot != std::string::npos) {
    if (!all_digits(rest.substr(dot + 1))) return 0;  // `.N`, render_plot's counter
    rest = rest.substr(0, dot);
  }
  if (!all_digits(rest) || rest.size() > 9) return 0;
  return std::stol(rest);
}

bool process_alive(long pid) {
  if (pid <= 0) return true;  // not a pid: never treat it as gone
  if (::kill(static_cast<pid_t>(pid), 0) != 0 && errno == ESRCH) return false;
  return proc_state(pid) != 'Z';
}

std::vector<std::string> remove_stale_temporaries(const std::string& dir, const std::string& name_prefix) {
  std::vector<std::string> stale;  // listed first, removed after: the listing is not disturbed
  std::error_code ec;
  for (const auto& entry : fs::directory_iterator(dir, ec)) {
    const std::string name = entry.path().filename().string();
    if (name.rfind(name_prefix, 0) != 0) continue;
    const long pid = temporary_owner_pid(name);
    if (pid != 0 && !process_alive(pid)) stale.push_back(name);
  }
  std::vector<std::string> removed;
  for (const std::string& name : stale) {
    std::error_code rm;
    fs::remove_all(fs::path(dir) / name, rm);
    if (!rm) removed.push_back(name);
  }
  std::sort(removed.begin(), removed.end());
  return removed;
}

}  // namespace f16race::io
