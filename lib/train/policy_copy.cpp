#include "train/policy_copy.hpp"

#include <filesystem>

#include "io/atomic_file.hpp"
#include "train/run_policy.hpp"
#include "train/trainer.hpp"

namespace f16race::train {

namespace fs = std::filesystem;

namespace {

// One folder (the run or a member): its own networks, re-saved policy-only beside its files.
// Returns how many tail members the folder's policy joins.
std::size_t copy_folder(const std::string& from, const fs::path& to, PolicyCopyReport& report) {
  const RunPolicy p = load_run_policy(from);  // validates: hash, format, loadable files, members
  const std::string name = fs::path(p.checkpoint_dir).filename().string();
  const fs::path dir = to / "checkpoint" / name;
  fs::create_directories(dir);
  io::write_file_atomic((to / "config.yaml").string(), io::read_file((fs::path(from) / "config.yaml").string()));
  io::write_file_atomic((to / "checkpoint" / "LATEST").string(), name);
  std::string meta = io::read_file((fs::path(p.checkpoint_dir) / "meta.yaml").string());
  if (!meta.empty() && meta.back() != '\n') meta += '\n';
  io::write_file_atomic((dir / "meta.yaml").string(), meta + "policy_only: true\n");
  p.ll->save((dir / "ll.pt").string(), agents::CheckpointContent::kPolicy);
  p.hl->save((dir / "hl.pt").string(), agents::CheckpointContent::kPolicy);
  report.folders += 1;
  report.bytes += static_cast<std::int64_t>(fs::file_size(dir / "ll.pt") + fs::file_size(dir / "hl.pt"));
  return p.hl_members.size();
}

}  // namespace

PolicyCopyReport write_policy_copy(const std::string& run_dir, const std::string& out_dir) {
  PolicyCopyReport report;
  // The members load_run_policy joined (a finished run with train.hl_tail_members > 1).
  const std::size_t members = copy_folder(run_dir, out_dir, report);
  for (std::size_t m = 1; m <= members; ++m) {
    copy_folder(member_dir(run_dir, m), member_dir(out_dir, m), report);
  }
  return report;
}

}  // namespace f16race::train
