#pragma once
// A training run's folder on disk: who owns it, whether it holds a run, and moving one aside.
// A run is never lost to a second writer or to a fresh `train` pointed at the wrong folder.
#include <string>
#include <vector>

namespace f16race::io {

// An advisory lock (flock) on RUN/.lock, held for the object's lifetime by the one process that
// writes the folder. flock locks belong to the open file, so a second lock conflicts even within
// one process, and the kernel drops the lock when the process dies (kill -9 included).
class RunFolderLock {
 public:
  // Creates the folder if needed and writes this process's pid into the file. Throws
  // io::InputError with one line naming the folder and the holder's pid when another process (or
  // another lock in this one) holds it.
  explicit RunFolderLock(const std::string& run_dir);
  // Unless claim() was called, leaves the file as it was found (its text back, or empty), so a
  // process that took the lock and then refused the folder changed nothing in it.
  ~RunFolderLock();
  // This process writes the folder: its pid stays in the file after the lock is released.
  void claim() { claimed_ = true; }
  RunFolderLock(const RunFolderLock&) = delete;
  RunFolderLock& operator=(const RunFolderLock&) = delete;
  RunFolderLock(RunFolderLock&& other) noexcept;
  RunFolderLock& operator=(RunFolderLock&& other) noexcept;

 private:
  void release();
  int fd_ = -1;
  bool claimed_ = false;
  bool existed_ = false;  // the file was there before this lock
  std::string found_;     // the text it held
};

// The pid (as RUN/.lock records it) of the process holding `run_dir`'s lock, or "" when no one
// holds it (or the folder has no lock file). Probes by taking the lock for an instant.
std::string run_folder_holder(const std::string& run_dir);

// The entries of `run_dir` that belong to a run (config.yaml, metrics.csv, a non-empty
// checkpoint/ or pool/, ...), sorted; empty when the folder is missing or holds none of them.
std::vector<std::string> run_data_in(const std::string& run_dir);

// Renames `run_dir` to the first free `run_dir.old-N` (N = 1, 2, ...) and returns that path, so
// an overwrite never deletes anything. Throws std::runtime_error naming both paths on failure.
std::string move_run_aside(const std::string& run_dir);

}  // namespace f16race::io
