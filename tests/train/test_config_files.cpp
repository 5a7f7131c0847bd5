// One set of defaults: configs/default.yaml lists the built-in defaults (a config of only the seed
// trains the same run), and every other shipped config is an overlay that sets only what differs.
// Run folders written before that (config version 1) still read as they were trained.
#include <gtest/gtest.h>
#include <yaml-cpp/yaml.h>

#include <map>
#include <string>

#include "io/yaml_config.hpp"
#include "train/train_config.hpp"

namespace f16race::train {
namespace {

std::string shipped_path(const std::string& name) { return std::string(F16RACE_CONFIG_DIR) + "/" + name; }

std::string resolved(const std::string& path) {
  return train_config_yaml(read_train_config(io::load_yaml_file(path), path));
}

// Every leaf of a YAML tree by its dotted path, as emitted text ([16, 16] for a list).
void leaves(const YAML::Node& n, const std::string& prefix, std::map<std::string, std::string>* out) {
  for (const auto& kv : n) {
    const std::string key = prefix.empty() ? kv.first.Scalar() : prefix + "." + kv.first.Scalar();
    if (kv.second.IsMap()) {
      leaves(kv.second, key, out);
    } else {
      YAML::Emitter e;
      e << YAML::Flow << kv.second;
      (*out)[key] = e.c_str();
    }
  }
}

bool same_value(const std::string& a, const std::string& b) {
  if (a == b) return true;
  try {
    return YAML::Load(a).as<double>() == YAML::Load(b).as<double>();
  } catch (const YAML::Exception&) {
    return false;
  }
}

TEST(ConfigFiles, OnlyTheSeedResolvesToTheDefaultConfig) {
  const TrainConfig seed_only = read_train_config(YAML::Load("seed: 1"), "seed_only.yaml");
  EXPECT_EQ(train_config_yaml(seed_only), resolved(shipped_path("default.yaml")));
  const TrainConfig empty = read_train_config(YAML::Load("{}"), "empty.yaml");
  EXPECT_EQ(train_config_yaml(empty), train_config_yaml(seed_only));
}

// The overlays hold their differences only: a key at the default's value would hide which
// settings make the config what it is, and would silently pin an old default.
TEST(ConfigFiles, EveryOtherShippedConfigSetsOnlyWhatDiffers) {
  std::map<std::string, std::string> defaults;
  leaves(YAML::Load(train_config_yaml(TrainConfig{})), "", &defaults);  // before the HL scales are derived
  for (const char* name : {"long.yaml", "paper.yaml", "smoke.yaml"}) {
    std::map<std::string, std::string> set;
    leaves(io::load_yaml_file(shipped_path(name)), "", &set);
    EXPECT_FALSE(set.empty()) << name;
    for (const auto& [key, value] : set) {
      ASSERT_TRUE(defaults.count(key)) << name << ": " << key << " is not a config key";
      EXPECT_FALSE(same_value(value, defaults[key])) << name << ": " << key << ": " << value
                                                     << " is the default; leave it out";
    }
    EXPECT_NO_THROW(resolved(shipped_path(name))) << name;
  }
}

// A run folder's config.yaml from before config_version (version 1) lists the keys of its build:
// one it lacks had that build's default, not today's. Read as a run folder it keeps its meaning;
// the same text as a user's config would take today's defaults.
TEST(ConfigFiles, AVersionOneRunFolderReadsWithTheDefaultsOfItsTime) {
  YAML::Node old = YAML::Load(train_config_yaml(TrainConfig{}));
  old.remove("config_version");
  old["race"].remove("goal_line_frac");
  old["race"].remove("goal_shift_up_frac");
  old["train"].remove("ll_throttle");
  YAML::Emitter e;
  e << old;
  const std::string text = e.c_str();
  const TrainConfig as_run = read_train_config(YAML::Load(text), "run/config.yaml", ConfigOrigin::kRunFolder);
  EXPECT_EQ(as_run.race.goal_line_frac, 0.0);
  EXPECT_EQ(as_run.race.goal_shift_up_frac, 0.0);
  EXPECT_EQ(as_run.loop.ll_throttle, LowLevelThrottle::kPolicy);
  EXPECT_EQ(as_run.race.time_limit_s, TrainConfig{}.race.time_limit_s);  // listed: kept
  const TrainConfig as_user = read_train_config(YAML::Load(text), "cfg.yaml");
  EXPECT_EQ(as_user.race.goal_line_frac, TrainConfig{}.race.goal_line_frac);
  EXPECT_EQ(as_user.loop.ll_throttle, LowLevelThrottle::kGovernor);
  // What train writes says its version, so it reads back as written.
  const std::string now = train_config_yaml(read_train_config(YAML::Load("{}"), "cfg.yaml"));
  EXPECT_EQ(now.rfind("config_version: 2\n", 0), 0u) << now;
  EXPECT_EQ(train_config_yaml(read_train_config(YAML::Load(now), "run/config.yaml", ConfigOrigin::kRunFolder)), now);
}

}  // namespace
}  // namespace f16race::train
