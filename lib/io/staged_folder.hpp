#pragma once
// A multi-file output (a tournament's folder, an export, a replay, a study's report) that appears
// whole or not at all. Everything is written into a staging folder beside it, `.NAME.tmp.PID`,
// flushed to disk, and swapped in with one rename (renameat2 RENAME_EXCHANGE): a reader, a crash
// or a kill -9 finds the earlier output or the new one, never a mix of the two.
//
// The swap replaces the whole folder, so a folder that holds anything but the command's own
// outputs is refused (one line listing what is in the way) instead of having it deleted.
#include <functional>
#include <string>

namespace f16race::io {

// Whether an entry name found in an existing output folder is one of the command's outputs.
using OutputNames = std::function<bool(const std::string& name)>;

class StagedFolder {
 public:
  // `final_dir`: where the output appears; `what`: the output in messages ("tournament");
  // `owns`: the command's own file names. Refuses (io::InputError, one line naming the folder and
  // the fix) a final_dir that is a file, or holds other names (temporaries of killed writers
  // aside), or contains the working directory. Then removes the stale staging folders of
  // final_dir left by killed processes and creates this one's.
  StagedFolder(std::string final_dir, std::string what, OutputNames owns);
  ~StagedFolder();  // without a commit: removes the staging folder and what was written there
  StagedFolder(const StagedFolder&) = delete;
  StagedFolder& operator=(const StagedFolder&) = delete;

  const std::string& staging() const { return staging_; }
  const std::string& final_dir() const { return final_; }

  // Runs `write(staging())`, checks final_dir again, flushes every file and folder of the
  // staging folder to disk and swaps it in; the earlier folder is then removed. A write error
  // (full disk, read-only folder: io::InputError or std::filesystem::filesystem_error) becomes
  // one io::FileWriteError line naming final_dir and saying that it was left as it was.
  void commit(const std::function<void(const std::string& staging_dir)>& write);

 private:
  void check_owned() const;
  void swap_in();
  [[noreturn]] void fail(const std::string& cause) const;

  std::string final_;  // as the user named it (messages)
  std::string real_;   // absolute, symlinks of the folder itself resolved: what is swapped
  std::string staging_;
  std::string what_;
  OutputNames owns_;
  bool committed_ = false;
};

// Flushes every regular file and folder below `dir`, and `dir` itself, to disk (fsync).
// Throws io::FileWriteError naming the first one that fails.
void sync_tree(const std::string& dir);

}  // namespace f16race::io
