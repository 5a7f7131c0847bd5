#pragma once
// `--set race.KEY=VALUE` for the commands that race trained runs (tournament, replay): the race
// settings they may change for every entry, with the ranges train's config reader allows. Only
// how the entries fly, never the tracks (tournament --tracks picks those).
#include <cmath>
#include <string>
#include <vector>

#include "io/input_error.hpp"
#include "io/csv_table.hpp"

namespace f16race::app {

struct RaceSetting {
  const char* key;  // under race:
  double lo, hi;
  double* value;    // where the command keeps it
};

// Applies each `race.KEY=VALUE` of `sets` to the setting named KEY; one line naming the
// assignment and what is allowed otherwise.
inline void apply_race_settings(const std::vector<std::string>& sets, const std::vector<RaceSetting>& allowed,
                                const char* command) {
  for (const std::string& s : sets) {
    std::string keys;
    for (const RaceSetting& a : allowed) keys += (keys.empty() ? "race." : ", race.") + std::string(a.key);
    const auto eq = s.find('=');
    const std::string key = s.substr(0, eq);
    const RaceSetting* hit = nullptr;
    for (const RaceSetting& a : allowed)
      if (key == std::string("race.") + a.key) hit = &a;
    if (eq == std::string::npos || hit == nullptr)
      throw io::InputError("--set '" + s + "': " + command + " sets " + keys + " (as KEY=VALUE)");
    const std::string text = s.substr(eq + 1);
    std::size_t used = 0;
    double v = NAN;
    try {
      v = std::stod(text, &used);
    } catch (const std::exception&) {
      used = 0;
    }
    if (used == 0 || used != text.size() || !(v >= hit->lo && v <= hit->hi))
      throw io::InputError("--set '" + s + "': " + key + " must be a number in [" + io::format_double(hit->lo) + ", " +
                           io::format_double(hit->hi) + "]");
    *hit->value = v;
  }
}

}  // namespace f16race::app
