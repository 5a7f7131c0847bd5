#pragma once
// The self-play pool's snapshots on disk (RUN/pool/step_N/{ll.pt, hl.pt}) and the rule that keeps
// a run resumable: a snapshot the last durable checkpoint names is never deleted. Pruning only
// retires a snapshot from the pool that opponents are drawn from; its folder goes once a later
// checkpoint that no longer names it is durable (release_retired), and a resume removes the
// folders its checkpoint does not name (remove_unnamed): snapshots taken after it are taken again.
#include <cstdint>
#include <functional>
#include <string>
#include <vector>

namespace f16race::train {

// "step_0000001234": a pool snapshot's (and a checkpoint's) folder name for its env steps.
std::string step_name(std::int64_t env_steps);

class SnapshotPool {
 public:
  // `writes`: this process owns the run folder (rank 0 or a single process); other ranks keep
  // the same lists and touch no file.
  SnapshotPool(std::string run_dir, int max_snapshots, bool writes);

  // Adds the snapshot of `env_steps`: `write(dir)` fills a staging folder that is renamed to
  // pool/step_N only when complete, so a kill never leaves half a snapshot under its name. Then
  // the oldest snapshots beyond max_snapshots, never `opponent`, are retired.
  void add(std::int64_t env_steps, std::int64_t opponent, const std::function<void(const std::string& dir)>& write);

  // After a checkpoint naming steps() and `opponent` is durable: deletes the retired folders.
  void release_retired(std::int64_t opponent);

  // At a resume, before the first snapshot: deletes every folder in pool/ that the checkpoint
  // (steps() and `opponent`) does not name, staging folders of a killed process among them.
  void remove_unnamed(std::int64_t opponent) const;

  std::string folder(std::int64_t env_steps) const;  // pool/step_N
  // The snapshots opponents are drawn from, oldest first; saved in and restored from trainer.pt.
  std::vector<std::int64_t>& steps() { return steps_; }
  const std::vector<std::int64_t>& steps() const { return steps_; }
  bool empty() const { return steps_.empty(); }

 private:
  std::string dir_;  // RUN/pool
  int max_snapshots_;
  bool writes_;
  std::vector<std::int64_t> steps_;
  std::vector<std::int64_t> retired_;  // out of steps_, folders kept until a checkpoint drops them
};

}  // namespace f16race::train
