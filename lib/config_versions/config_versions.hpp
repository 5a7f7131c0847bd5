#pragma once
// The one place that knows how configs changed over time. A run folder's config.yaml lists every
// key of the build that wrote it; since version 2 it also says `config_version: 2`. Older files
// (version 1, no such key) were written when some defaults differed and some keys existed that
// this build no longer reads: migrate() brings any config to the current version before the
// strict readers (race::read_race_config, train::read_train_config) see it.
#include <yaml-cpp/yaml.h>

#include <string>

namespace f16race::config_versions {

// The version train writes at the top of every config.yaml (`config_version: 2`).
inline constexpr int kCurrent = 2;
inline constexpr const char* kVersionKey = "config_version";

// Who wrote the file: a user (a config and --set, an overlay on today's defaults), or train (a run
// folder's config.yaml: a key it lacks had the default of the version it was written at).
enum class Written { kByUser, kByTrain };
// Who wrote the file at `path`, for readers that take any config (RaceEnv, `race`): train, when it
// is the config.yaml of a run folder (beside its checkpoint/ or metrics.csv), else a user.
Written written_by(const std::string& path);

// Brings `root` (a handle: the tree is changed in place, so errors keep their file lines) to the
// current version and removes the version key:
//  - config_version, when given, must be an integer in [1, kCurrent];
//  - a file train wrote before version 2 gets every key whose default has changed since, at the
//    value it had then, where the file does not list it;
//  - a retired key (a switch that was measured and removed) is dropped when it holds what this
//    build does; any other value throws io::ConfigError naming `source`, the key, and the commit
//    to build to use it;
//  - a retired value of a key that stays (train.ll_pilot: residual) throws the same way.
void migrate(YAML::Node root, const std::string& source, Written who);

}  // namespace f16race::config_versions
