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
