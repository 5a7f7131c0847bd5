#include "io/yaml_config.hpp"

#include <algorithm>
#include <filesystem>
#include <fstream>
#include <set>
#include <sstream>

namespace f16race::io {

YAML::Node load_yaml_file(const std::string& path) {
  if (path.empty()) throw ConfigError("an empty config path (an unset variable?); pass the path of a .yaml file");
  // A directory opens as a stream that reads nothing: it would pass as an empty config.
  std::error_code ec;
  if (std::filesystem::is_directory(path, ec))
    throw ConfigError(path + ": is a directory, not a config file; pass the path of a .yaml file");
  // A device or a pipe may never end (/dev/zero) or be read once only: configs are files.
  if (std::filesystem::exists(path, ec) && !std::filesystem::is_regular_file(path, ec))
    throw ConfigError(path + ": is not a regular file; pass the path of a .yaml file");
  std::ifstream f(path, std::ios::binary);
  if (!f) throw ConfigError(path + ": cannot open the config file (check the path)");
  std::stringstream text;
  text << f.rdbuf();
  return parse_yaml_text(text.str(), path);
}

YAML::Node parse_yaml_text(const std::string& text, const std::string& source) {
  try {
    return YAML::Load(text);
  } catch (const YAML::ParserException& e) {
    throw ConfigError(source + ":" + std::to_string(e.mark.line + 1) + ": YAML syntax error: " + e.msg);
  }
}

YAML::Node load_yaml_with_overrides(const std::string& path, const std::vector<std::string>& overrides) {
  YAML::Node root = load_yaml_file(path);
  for (const std::string& s : overrides) apply_override(root, s);
  return root;
}

void apply_override(YAML::Node& root, const std::string& assignment) {
  const auto eq = assignment.find('=');
  if (eq == std::string::npos || eq == 0)
    throw ConfigError("--set '" + assignment + "': expected key.path=value, e.g. --set race.n_env=256");
  const std::string path = assignment.substr(0, eq);
  YAML::Node value;
  try {
    value = YAML::Load(assignment.substr(eq + 1));
  } catch (const YAML::ParserException& e) {
    throw ConfigError("--set '" + assignment + "': value is not valid YAML: " + e.msg);
  }
  // The value carries where it came from, so an error about it names the --set, not the file.
  value.SetTag(kOverrideTag + assignment);
  // Walk with fresh handles: yaml-cpp nodes are references, so plain `node = node[key]`
  // assignment would overwrite the tree instead of descending into it.
  std::vector<std::string> keys;
  std::stringstream ss(path);
  for (std::string k; std::getline(ss, k, '.');) {
    if (k.empty()) throw ConfigError("--set '" + assignment + "': empty key in the path");
    keys.push_back(k);
  }
  std::vector<YAML::Node> chain{root};
  for (std::size_t i = 0; i + 1 < keys.size(); ++i) {
    YAML::Node next = chain.back()[keys[i]];
    if (next && !next.IsMap())
      throw ConfigError("--set '" + assignment + "': '" + keys[i] + "' is a value, not a section");
    chain.push_back(next);
  }
  chain.back()[keys.back()] = value;
}

ConfigReader::ConfigReader(YAML::Node node, std::string source, std::string path)
    : node_(std::move(node)), source_(std::move(source)), path_(std::move(path)) {
  if (node_ && !node_.IsNull() && !node_.IsMap()) {
    throw ConfigError(source_ + ": '" + (path_.empty() ? std::string("(top level)") : path_) +
                      "' must be a mapping of key: value pairs");
  }
  // yaml-cpp keeps both entries of a repeated key and lookups see only the first, so
  // `n_env: 6` then `n_env: 4` would silently train 6 envs.
  if (node_ && node_.IsMap()) {
    std::set<std::string> seen;
    for (const auto& kv : node_) {
      if (!kv.first.IsScalar()) continue;
      if (!seen.insert(kv.first.Scalar()).second) {
        const int line = kv.first.Mark().line;
        throw ConfigError(source_ + (line >= 0 ? ":" + std::to_string(line + 1) : std::string()) + ": " +
                          key_path(kv.first.Scalar().c_str()) + " is given twice; keep one of them");
      }
    }
  }
}

bool ConfigReader::has(const char* key) const { return node_ && node_.IsMap() && node_[key]; }

std::string ConfigReader::origin(const YAML::Node& value) const {
  const std::string& tag = value.Tag();
  if (tag.rfind(kOverrideTag, 0) == 0) return "--set " + tag.substr(std::string(kOverrideTag).size());
  return source_;
}

void ConfigReader::fail(const char* key, const std::string& what) const {
  throw ConfigError((has(key) ? origin(node_[key]) : source_) + ": " + key_path(key) + ": " + what);
}

namespace {
std::string scalar_text(const YAML::Node& n) {
  // `key:` with nothing after it, or `--set key=`, is a null node: neither a value nor a mapping.
  if (n.IsNull()) return "an empty value";
  if (n.IsScalar()) return "'" + n.Scalar() + "'";
  return n.IsSequence() ? "a list" : "a mapping";
}
}  // namespace

void ConfigReader::read(const char* key, double* value, double lo, double hi) {
  used_.insert(key);
  if (!has(key)) return;
  const YAML::Node n = node_[key];
  double v;
  try {
    if (!n.IsScalar()) throw YAML::BadConversion(n.Mark());
    v = n.as<double>();
  } catch (const YAML::BadConversion&) {
    fail(key, "expected a number, got " + scalar_text(n));
  }
  if (!(v >= lo && v <= hi)) {
    std::ostringstream m;
    m << "value " << v << " is out of range; allowed [" << lo << ", " << hi << "]";
    fail(key, m.str());
  }
  *value = v;
}

void ConfigReader::read(const char* key, int* value, int lo, int hi) {
  used_.insert(key);
  if (!has(key)) return;
  const YAML::Node n = node_[key];
  long long v;
  try {
    if (!n.IsScalar()) throw YAML::BadConversion(n.Mark());
    v = n.as<long long>();
  } catch (const YAML::BadConversion&) {
    fail(key, "expected an integer, got " + scalar_text(n));
  }
  if (v < lo || v > hi) {
    fail(key, "value " + std::to_string(v) + " is out of range; allowed [" + std::to_string(lo) + ", " +
                  std::to_string(hi) + "]");
  }
  *value = static_cast<int>(v);
}

void ConfigReader::read(const char* key, std::uint64_t* value) {
  used_.insert(key);
  if (!has(key)) return;
  const YAML::Node n = node_[key];
  try {
    if (!n.IsScalar() || n.Scalar().empty() || n.Scalar()[0] == '-') throw YAML::BadConversion(n.Mark());
    *value = n.as<std::uint64_t>();
  } catch (const YAML::BadConversion&) {
    fail(key, "expected a non-negative integer, got " + scalar_text(n));
  }
}

void ConfigReader::read(const char* key, bool* value) {
  used_.insert(key);
  if (!has(key)) return;
  const YAML::Node n = node_[key];
  try {
    if (!n.IsScalar()) throw YAML::BadConversion(n.Mark());
    *value = n.as<bool>();
  } catch (const YAML::BadConversion&) {
    fail(key, "expected true or false, got " + scalar_text(n));
  }
}

void ConfigReader::read(const char* key, std::string* value, const std::vector<std::string>& allowed) {
  used_.insert(key);
  if (!has(key)) return;
  const YAML::Node n = node_[key];
  if (!n.IsScalar()) fail(key, "expected a string, got " + scalar_text(n));
  const std::string v = n.Scalar();
  if (!allowed.empty()) {
    bool ok = false;
    std::string list;
    for (const std::string& a : allowed) {
      ok = ok || a == v;
      list += (list.empty() ? "" : ", ") + a;
    }
    if (!ok) fail(key, "'" + v + "' is not one of: " + list);
  }
  *value = v;
}

void ConfigReader::read(const char* key, std::vector<int>* value, int lo, int hi) {
  used_.insert(key);
  if (!has(key)) return;
  const YAML::Node n = node_[key];
  if (!n.IsSequence()) fail(key, "expected a list of integers like [64, 64], got " + scalar_text(n));
  std::vector<int> out;
  for (std::size_t i = 0; i < n.size(); ++i) {
    long long v;
    try {
      v = n[i].as<long long>();
    } catch (const YAML::BadConversion&) {
      fail(key, "element " + std::to_string(i) + " is not an integer");
    }
    if (v < lo || v > hi)
      fail(key, "element " + std::to_string(i) + " = " + std::to_string(v) + " is out of range; allowed [" +
                    std::to_string(lo) + ", " + std::to_string(hi) + "]");
    out.push_back(static_cast<int>(v));
  }
  if (out.empty()) fail(key, "the list must not be empty");
  *value = out;
}

void ConfigReader::read(const char* key, std::vector<double>* value, double lo, double hi) {
  used_.insert(key);
  if (!has(key)) return;
  const YAML::Node n = node_[key];
  if (!n.IsSequence()) fail(key, "expected a list of numbers like [8, 20], got " + scalar_text(n));
  std::vector<double> out;
  for (std::size_t i = 0; i < n.size(); ++i) {
    double v;
    try {
      v = n[i].as<double>();
    } catch (const YAML::BadConversion&) {
      fail(key, "element " + std::to_string(i) + " is not a number");
    }
    if (!(v >= lo && v <= hi)) {
      std::ostringstream m;
      m << "element " << i << " = " << n[i].Scalar() << " is out of range; allowed [" << lo << ", " << hi << "]";
      fail(key, m.str());
    }
    out.push_back(v);
  }
  if (out.empty()) fail(key, "the list must not be empty");
  *value = out;
}

void ConfigReader::read(const char* key, std::vector<std::string>* value, const std::vector<std::string>& allowed) {
  used_.insert(key);
  if (!has(key)) return;
  const YAML::Node n = node_[key];
  if (!n.IsSequence()) fail(key, "expected a list like [a, b], got " + scalar_text(n));
  std::vector<std::string> out;
  for (std::size_t i = 0; i < n.size(); ++i) {
    if (!n[i].IsScalar()) fail(key, "element " + std::to_string(i) + " is not a string");
    const std::string v = n[i].Scalar();
    if (!allowed.empty() && std::find(allowed.begin(), allowed.end(), v) == allowed.end()) {
      std::string list;
      for (const std::string& a : allowed) list += (list.empty() ? "" : ", ") + a;
      fail(key, "element " + std::to_string(i) + " '" + v + "' is not one of: " + list);
    }
    if (std::find(out.begin(), out.end(), v) != out.end()) fail(key, "'" + v + "' is listed twice");
    out.push_back(v);
  }
  if (out.empty()) fail(key, "the list must not be empty");
  *value = out;
}

ConfigReader ConfigReader::child(const char* key) {
  used_.insert(key);
  if (!has(key)) return ConfigReader(YAML::Node(), source_, key_path(key));
  const YAML::Node n = node_[key];
  // `race: ~` or `race:` with nothing under it reads like a section yet sets nothing: say so, as
  // it may be a section whose keys lost their indentation.
  if (n.IsNull()) {
    const int line = n.Mark().line;
    throw ConfigError(origin(n) + (line >= 0 ? ":" + std::to_string(line + 1) : std::string()) + ": " + key_path(key) +
                      " is an empty section; give its keys indented under it, or leave it out to take every default");
  }
  return ConfigReader(n, origin(n), key_path(key));
}

void ConfigReader::finish() const {
  if (!node_ || !node_.IsMap()) return;
  for (const auto& kv : node_) {
    const std::string k = kv.first.as<std::string>();
    if (!used_.count(k)) {
      std::string known;
      for (const std::string& u : used_) known += (known.empty() ? "" : ", ") + u;
      throw ConfigError(origin(kv.second) + ": unknown key '" + key_path(k.c_str()) + "' (known here: " + known + ")");
    }
  }
}

}  // namespace f16race::io
