#include "config_versions/config_versions.hpp"

#include <filesystem>
#include <string>

#include "io/yaml_config.hpp"

namespace f16race::config_versions {
namespace {

// A key under a section (`section.key`, or `race.track.key`) and a value as YAML text.
struct KeyValue {
  const char* section;  // "race", "race.track", "ll", "hl", "train" or "pool"
  const char* key;
  const char* value;
};

// Version 1 -> 2: the built-in defaults became configs/default.yaml's (one set of defaults).
// A version-1 file that does not list one of these keys was trained with the value here.
constexpr KeyValue kVersion1Defaults[] = {
    {"race", "n_env", "64"},
    {"race", "time_limit_s", "120"},
    {"race.track", "n_waypoints", "12"},
    {"race", "autopilot_shift_up_frac", "0"},
    {"race", "goal_line_frac", "0"},
    {"race", "goal_shift_up_frac", "0"},
    {"ll", "init_log_std", "0"},
    {"hl", "agent", "es_d3"},
    {"hl", "n_steps_per_update", "10"},
    {"hl", "minibatch_chunks", "1"},
    {"train", "total_env_steps", "200000"},
    {"train", "ll_throttle", "policy"},
    {"train", "hl_tail_share", "0"},
    {"train", "hl_tail_members", "1"},
    {"pool", "p_center_tail", "0"},
};

// Switches that were measured, did not help, and were removed: the value every build since
// behaves as, and the last commit that reads the key (the experiment's record names it too).
struct Retired {
  const char* section;
  const char* key;
  const char* value;
  const char* last_commit;
};
constexpr Retired kRetired[] = {
    {"race", "governor_holds", "mach", "d48ab5e"},
    {"race", "governor_band_mach", "0.04", "c3a8ae5"},
    {"race", "governor_sets_throttle_at_cap", "false", "0b55350"},
    {"race", "goal_origin", "center", "b8c9f8c"},
    {"race", "lane_scales_with_radius", "false", "0bda7d6"},
    {"race", "preview_on_line", "false", "b8dcef3"},
    {"race", "observe_team_lanes", "false", "b8c9f8c"},
    {"race", "lane_error_average_s", "0", "46d4f04"},
    {"race", "w_tube_wall", "0", "833c6d1"},
    {"race", "w_track_progress", "0", "9d0d451"},
    {"race", "tube_wall_frac", "0.8", "833c6d1"},
    {"ll", "inference", "eigen", "b8c9f8c"},
    {"ll", "normalize_returns", "false", "c8c67be"},
    {"ll", "init_at_trim", "false", "c8c67be"},
    {"hl", "explore", "aircraft", "b8c9f8c"},
    {"hl", "team_explore_scale", "1", "b8c9f8c"},
    {"hl", "critic", "shared", "b8c9f8c"},
    {"hl", "team_target", "sum", "b8c9f8c"},
    {"hl", "lateral", "aircraft", "b8c9f8c"},
    {"hl", "inference", "eigen", "b8c9f8c"},
    {"train", "hl_average_share", "0", "b8c9f8c"},
    {"train", "ll_choice_snapshots", "0", "f91e291"},
    {"train", "ll_choice_races", "384", "f91e291"},
    {"train", "ll_both_teams", "false", "c8c67be"},
    {"train", "ll_residual_scale", "0.5", "5761eb7"},
    {"pool", "p_center", "0", "b8c9f8c"},
    {"pool", "p_autopilot", "0", "e9c8edf"},
};

// Values of live keys that were measured and removed: the key stays, this value is refused.
constexpr Retired kRetiredValues[] = {
    {"train", "ll_pilot", "residual", "5761eb7"},
};

// The mapping at a dotted section path, or an undefined node when a part is missing or not a map.
// (Handles move with reset(): yaml-cpp's `node = other` would write other's value into the tree.)
YAML::Node section_of(YAML::Node root, const std::string& dotted) {
  YAML::Node node = root;
  std::size_t start = 0;
  while (start <= dotted.size()) {
    const std::size_t dot = dotted.find('.', start);
    const std::string part = dotted.substr(start, dot == std::string::npos ? std::string::npos : dot - start);
    if (!node.IsMap() || !node[part] || !node[part].IsMap()) return YAML::Node(YAML::NodeType::Undefined);
    node.reset(node[part]);
    if (dot == std::string::npos) break;
    start = dot + 1;
  }
  return node;
}

// `n` holds `value`: the same text, or the same number (0 and 0.0) or boolean (false and no).
bool holds(const YAML::Node& n, const char* value) {
  if (!n.IsScalar()) return false;
  if (n.Scalar() == value) return true;
  const YAML::Node want = YAML::Load(value);
  try {
    return n.as<double>() == want.as<double>();
  } catch (const YAML::BadConversion&) {
  }
  try {
    return n.as<bool>() == want.as<bool>();
  } catch (const YAML::BadConversion&) {
  }
  return false;
}

// Where a value came from: its --set assignment (io::apply_override tags it), else the file.
std::string origin(const YAML::Node& value, const std::string& source) {
  const std::string& tag = value.Tag();
  const std::string set_tag = io::kOverrideTag;
  if (tag.rfind(set_tag, 0) == 0) return "--set " + tag.substr(set_tag.size());
  return source;
}

int read_version(YAML::Node* root, const std::string& source, Written who) {
  if (!root->IsMap() || !(*root)[kVersionKey]) return who == Written::kByTrain ? 1 : kCurrent;
  const YAML::Node n = (*root)[kVersionKey];
  int version = 0;
  try {
    version = n.IsScalar() ? n.as<int>() : 0;
  } catch (const YAML::BadConversion&) {
  }
  if (version < 1 || version > kCurrent)
    throw io::ConfigError(origin(n, source) + ": " + kVersionKey + ": " + (n.IsScalar() ? n.Scalar() : "(not a number)") +
                          " is not a config version this build reads (1 to " + std::to_string(kCurrent) +
                          "); a newer f16race wrote it, or leave the key out");
  root->remove(kVersionKey);
  return version;
}

void fill_version1_defaults(YAML::Node root) {
  for (const KeyValue& kv : kVersion1Defaults) {
    YAML::Node section = section_of(root, kv.section);
    if (!section.IsDefined()) {  // a section the file leaves out: make it, to hold the old value
      const std::string s = kv.section;
      const auto dot = s.find('.');
      YAML::Node parent = dot == std::string::npos ? root : section_of(root, s.substr(0, dot));
      if (!parent.IsDefined() || !parent.IsMap()) continue;  // not a mapping: the reader says so
      const std::string leaf = dot == std::string::npos ? s : s.substr(dot + 1);
      if (parent[leaf] && !parent[leaf].IsMap()) continue;
      parent[leaf] = YAML::Node(YAML::NodeType::Map);
      section.reset(parent[leaf]);
    }
    if (!section[kv.key]) section[kv.key] = YAML::Load(kv.value);
  }
}

void drop_retired_keys(YAML::Node root, const std::string& source) {
  for (const Retired& r : kRetired) {
    YAML::Node section = section_of(root, r.section);
    if (!section.IsDefined() || !section[r.key]) continue;
    const YAML::Node n = section[r.key];
    if (!holds(n, r.value))
      throw io::ConfigError(origin(n, source) + ": " + r.section + "." + r.key + ": " +
                            (n.IsScalar() ? n.Scalar() : std::string("(not a value)")) +
                            " was removed, measured not to help (this build behaves as " + r.value +
                            "); build commit " + r.last_commit + " to use it");
    section.remove(r.key);
  }
  for (const Retired& r : kRetiredValues) {
    YAML::Node section = section_of(root, r.section);
    if (!section.IsDefined() || !section[r.key] || !holds(section[r.key], r.value)) continue;
    throw io::ConfigError(origin(section[r.key], source) + ": " + r.section + "." + r.key + ": " + r.value +
                          " was removed, measured not to help; build commit " + r.last_commit + " to use it");
  }
}

}  // namespace

Written written_by(const std::string& path) {
  namespace fs = std::filesystem;
  std::error_code ec;
  const fs::path p(path);
  if (p.filename() != "config.yaml") return Written::kByUser;
  const fs::path dir = p.parent_path().empty() ? fs::path(".") : p.parent_path();
  const bool run = fs::is_directory(dir / "checkpoint", ec) || fs::is_regular_file(dir / "metrics.csv", ec);
  return run ? Written::kByTrain : Written::kByUser;
}

void migrate(YAML::Node root, const std::string& source, Written who) {
  if (!root.IsMap()) return;  // empty, or not a mapping: the reader says what is wrong
  const int version = read_version(&root, source, who);
  if (version == 1) fill_version1_defaults(root);
  drop_retired_keys(root, source);
}

}  // namespace f16race::config_versions
