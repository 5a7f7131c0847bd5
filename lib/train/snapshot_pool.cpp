#include "train/snapshot_pool.hpp"

#include <unistd.h>

#include <algorithm>
#include <cstdio>
#include <filesystem>
#include <system_error>

#include "io/atomic_file.hpp"

namespace f16race::train {

namespace fs = std::filesystem;

std::string step_name(std::int64_t env_steps) {
  char buf[32];
  std::snprintf(buf, sizeof buf, "step_%010lld", static_cast<long long>(env_steps));
  return buf;
}

SnapshotPool::SnapshotPool(std::string run_dir, int max_snapshots, bool writes)
    : dir_((fs::path(run_dir) / "pool").string()), max_snapshots_(max_snapshots), writes_(writes) {}

std::string SnapshotPool::folder(std::int64_t env_steps) const { return (fs::path(dir_) / step_name(env_steps)).string(); }

void SnapshotPool::add(std::int64_t env_steps, std::int64_t opponent,
                       const std::function<void(const std::string& dir)>& write) {
  if (writes_) {
    const fs::path final_dir = folder(env_steps);
    const fs::path staging = fs::path(dir_) / ("." + step_name(env_steps) + ".tmp." + std::to_string(::getpid()));
    std::error_code ec;
    try {
      fs::remove_all(staging);
      fs::create_directories(staging);
      write(staging.string());
      fs::remove_all(final_dir);  // a folder of the same name is unnamed by any checkpoint
      fs::rename(staging, final_dir);
    } catch (const fs::filesystem_error& e) {
      fs::remove_all(staging, ec);
      throw io::FileWriteError(final_dir.string() + ": cannot write the pool snapshot (" + e.code().message() +
                               "); the last checkpoint and its pool are intact: free space and --resume");
    } catch (...) {
      fs::remove_all(staging, ec);
      throw;
    }
  }
  steps_.push_back(env_steps);
  while (static_cast<int>(steps_.size()) > max_snapshots_) {
    // Oldest first, but never the snapshot the current phase is playing against.
    auto victim = steps_.begin();
    if (*victim == opponent) ++victim;
    retired_.push_back(*victim);
    steps_.erase(victim);
  }
}

void SnapshotPool::release_retired(std::int64_t opponent) {
  if (writes_)
    for (const std::int64_t r : retired_) {
      if (r == opponent || std::find(steps_.begin(), steps_.end(), r) != steps_.end()) continue;
      std::error_code ec;  // a folder that cannot go now is an unnamed one the next resume removes
      fs::remove_all(folder(r), ec);
    }
  retired_.clear();
}

void SnapshotPool::remove_unnamed(std::int64_t opponent) const {
  if (!writes_) return;
  std::vector<std::string> named;
  for (const std::int64_t s : steps_) named.push_back(step_name(s));
  if (opponent >= 0) named.push_back(step_name(opponent));
  std::error_code ec;
  std::vector<fs::path> doomed;
  for (const auto& entry : fs::directory_iterator(dir_, ec)) {
    const std::string name = entry.path().filename().string();
    if (std::find(named.begin(), named.end(), name) == named.end()) doomed.push_back(entry.path());
  }
  for (const fs::path& p : doomed) fs::remove_all(p, ec);
}

}  // namespace f16race::train
