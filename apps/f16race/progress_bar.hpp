#pragma once
// The one progress bar of the terminal commands (train, tournament): redraws the current line as
// "[####....] TEXT" and clears what an earlier, longer line left. Callers print it only on a tty.
#include <algorithm>
#include <cstdio>
#include <string>

namespace f16race::app {

inline void print_progress_bar(double fraction, int width, const std::string& text) {
  const int filled = std::clamp(static_cast<int>(fraction * width), 0, width);
  std::printf("\r[%s%s] %s\x1b[K", std::string(filled, '#').c_str(), std::string(width - filled, '.').c_str(),
              text.c_str());
  std::fflush(stdout);
}

}  // namespace f16race::app
