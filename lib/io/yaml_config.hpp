#pragma once
// Typed, validated reading of YAML configs into plain structs. Every error is one line naming
// the file, the dotted key path, the offending value and what is allowed; unknown keys are
// errors too (a typo must never silently fall back to a default).
#include <yaml-cpp/yaml.h>

#include <cstdint>
#include <set>
#include <stdexcept>
#include <string>
#include <vector>

#include "io/input_error.hpp"

namespace f16race::io {

class ConfigError : public InputError {
 public:
  using InputError::InputError;
};

// Loads a YAML file (ConfigError when missing or malformed, with the line).
YAML::Node load_yaml_file(const std::string& path);
// Parses YAML text read from `source` (ConfigError naming it and the line when malformed).
YAML::Node parse_yaml_text(const std::string& text, const std::string& source);

// Applies `key.path=value` overrides (from --set) onto a YAML tree; the value is parsed as YAML,
// so numbers, booleans, strings and [lists] work. Unknown keys are caught later by the reader.
void apply_override(YAML::Node& root, const std::string& assignment);
// The tag apply_override gives a value, followed by its assignment: errors name the --set.
inline constexpr const char* kOverrideTag = "!f16race-set:";

// load_yaml_file(path), then every override in order (what `--config F --set k=v ...` means).
YAML::Node load_yaml_with_overrides(const std::string& path, const std::vector<std::string>& overrides);

// Why a key is gone (ConfigReader::retired's error): what removed it and the last commit that reads it.
struct Retirement {
  const char* removed;      // "removed <removed>": a commit, or the notebook entry whose verdict it was
  const char* last_commit;  // build this commit to use the key
};
// Issue 51's keys (experiment switches measured not to help, a test hook).
inline constexpr Retirement kIssue51Keys{"in 06d4cb7", "b8c9f8c"};
// train.ll_both_teams: measured not to help (docs/notebook/69-both-teams-samples.md).
inline constexpr Retirement kNotebook69Keys{"after docs/notebook/69's verdict", "c8c67be"};
// ll.normalize_returns: measured not to help (docs/notebook/70-return-normalisation.md).
inline constexpr Retirement kNotebook70Keys{"after docs/notebook/70's verdict", "c8c67be"};
// ll.init_at_trim: measured not to help (docs/notebook/71-trim-centred-initial-action.md).
inline constexpr Retirement kNotebook71Keys{"after docs/notebook/71's verdict", "c8c67be"};
// race.lane_error_average_s: measured not to help (docs/notebook/74-the-lane-error-average.md).
inline constexpr Retirement kNotebook74Keys{"after docs/notebook/74's verdict", "46d4f04"};
// pool.p_autopilot: measured not to help (docs/notebook/73-the-autopilot-in-the-pool.md).
inline constexpr Retirement kNotebook73Keys{"after docs/notebook/73's verdict", "e9c8edf"};
// race.governor_sets_throttle_at_cap: measured not to help (docs/notebook/, entries 78 and 79).
inline constexpr Retirement kNotebook78Keys{"after docs/notebook/78's and 79's verdicts", "0b55350"};
// race.governor_band_mach: measured not to help (docs/notebook/80-a-governor-with-less-droop.md).
inline constexpr Retirement kNotebook80Keys{"after docs/notebook/80's verdict", "c3a8ae5"};
// race.preview_on_line: measured not to help (docs/notebook/88-the-preview-on-the-racing-line.md).
inline constexpr Retirement kNotebook88Keys{"after docs/notebook/88's verdict", "b8dcef3"};
// race.lane_scales_with_radius: measured not to help
// (docs/notebook/92-lanes-inside-the-local-tube-at-full-throttle.md).
inline constexpr Retirement kNotebook92Keys{"after docs/notebook/92's verdict", "0bda7d6"};
// race.w_tube_wall, race.tube_wall_frac: measured not to help (docs/notebook/, entries 94 and 95).
inline constexpr Retirement kNotebook95Keys{"after docs/notebook/94's and 95's verdicts", "833c6d1"};
// race.governor_holds (airspeed): measured not to help (docs/notebook/96-height-is-pace-under-a-mach-governor.md).
inline constexpr Retirement kNotebook96Keys{"after docs/notebook/96's verdict", "d48ab5e"};
// train.ll_choice_snapshots, train.ll_choice_races: the low level chosen at the freeze, measured
// not to help the team (docs/notebook/105-the-low-level-chosen-in-training.md).
inline constexpr Retirement kNotebook105Keys{"after docs/notebook/105's verdict", "f91e291"};

// Reads one mapping. Keys are consumed by the read_* calls; finish() rejects leftovers.
class ConfigReader {
 public:
  ConfigReader(YAML::Node node, std::string source, std::string path = "");

  // A missing key keeps the struct's default. Ranges are inclusive.
  void read(const char* key, double* value, double lo, double hi);
  void read(const char* key, int* value, int lo, int hi);
  void read(const char* key, std::uint64_t* value);
  void read(const char* key, bool* value);
  void read(const char* key, std::string* value, const std::vector<std::string>& allowed);
  void read(const char* key, std::vector<int>* value, int lo, int hi);
  void read(const char* key, std::vector<double>* value, double lo, double hi);
  // A non-empty list of distinct strings, each one of `allowed` (any string if it is empty).
  void read(const char* key, std::vector<std::string>* value, const std::vector<std::string>& allowed);
  // A key this build no longer reads. A run folder's config.yaml lists every key of the build that
  // wrote it, so older runs still name it: at `value`, what this build behaves as (a number or
  // boolean compares as one: 0 and 0.0), it is consumed and changes nothing; at any other value
  // the config asks for code that is gone, and the error names the key, the value and the commits.
  void retired(const char* key, const char* value, const Retirement& why = kIssue51Keys);
  // A key another reader of this mapping takes care of: not an unknown key here.
  void skip(const char* key) { used_.insert(key); }

  // Sub-mapping (possibly absent: then an empty reader that keeps every default).
  ConfigReader child(const char* key);
  bool has(const char* key) const;
  // Throws ConfigError for any key of this mapping that no read_*/child call asked for.
  void finish() const;

  const std::string& source() const { return source_; }
  std::string key_path(const char* key) const { return path_.empty() ? key : path_ + "." + key; }
  [[noreturn]] void fail(const char* key, const std::string& what) const;

 private:
  // Where `value` came from: its --set assignment (apply_override tags it), else the file.
  std::string origin(const YAML::Node& value) const;

  YAML::Node node_;
  std::string source_;
  std::string path_;
  std::set<std::string> used_;
  std::set<std::string> retired_;  // consumed, but not offered as known keys in an error
};

// The mirror of ConfigReader with the same calls: writes the current values into a YAML tree,
// so one bind function both reads a config and emits the resolved one (no key listed twice).
class ConfigWriter {
 public:
  explicit ConfigWriter(YAML::Node node) : node_(std::move(node)) {}
  void read(const char* key, double* value, double, double) { node_[key] = *value; }
  void read(const char* key, int* value, int, int) { node_[key] = *value; }
  void read(const char* key, std::uint64_t* value) { node_[key] = *value; }
  void read(const char* key, bool* value) { node_[key] = *value; }
  void read(const char* key, std::string* value, const std::vector<std::string>&) { node_[key] = *value; }
  void retired(const char*, const char*, const Retirement& = kIssue51Keys) {}  // never written again
  void skip(const char*) {}
  void read(const char* key, std::vector<int>* value, int, int) {
    YAML::Node seq(YAML::NodeType::Sequence);
    seq.SetStyle(YAML::EmitterStyle::Flow);
    for (int v : *value) seq.push_back(v);
    node_[key] = seq;
  }
  ConfigWriter child(const char* key) { return ConfigWriter(node_[key]); }
  void finish() const {}
  const std::string& source() const { return source_; }

 private:
  YAML::Node node_;
  std::string source_ = "(resolved config)";
};

}  // namespace f16race::io
