#pragma once
// `--set race.KEY=VALUE` for the commands that race trained runs (tournament, replay): the race
// settings they may change for every entry, read by the config reader train uses (the same
// parsing, ranges and one-line errors). Only how the entries fly, never the tracks
// (tournament --tracks picks those).
#include <yaml-cpp/yaml.h>

#include <string>
#include <vector>

#include "io/input_error.hpp"
#include "io/yaml_config.hpp"

namespace f16race::app {

struct RaceSetting {
  const char* key;  // under race:
  double lo, hi;
  double* value;    // where the command keeps it
};

// Applies every `race.KEY=VALUE` of `sets` to its setting; an assignment outside race:, a key not
// in `allowed`, a wrong type or an out-of-range value is one line naming the --set.
inline void apply_race_settings(const std::vector<std::string>& sets, const std::vector<RaceSetting>& allowed,
                                const char* command) {
  if (sets.empty()) return;
  YAML::Node root(YAML::NodeType::Map);
  for (const std::string& s : sets) {
    if (s.rfind("race.", 0) != 0) {
      std::string keys;
      for (const RaceSetting& a : allowed) keys += (keys.empty() ? "race." : ", race.") + std::string(a.key);
      throw io::InputError("--set '" + s + "': " + command + " sets " + keys + " (as KEY=VALUE)");
    }
    io::apply_override(root, s);
  }
  io::ConfigReader race(root["race"], std::string("--set (") + command + ")", "race");
  for (const RaceSetting& a : allowed) race.read(a.key, a.value, a.lo, a.hi);
  race.finish();  // another key: named, with the ones this command sets
}

}  // namespace f16race::app
