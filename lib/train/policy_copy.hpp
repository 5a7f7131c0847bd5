#pragma once
// A policy-only copy of a trained run: what loading its policy reads (train/run_policy.hpp) and
// nothing a resume alone needs, so a trained team can be shared or shipped small (issue 52).
#include <cstdint>
#include <string>

namespace f16race::train {

struct PolicyCopyReport {
  int folders = 0;          // the run, and each tail member (train.hl_tail_members)
  std::int64_t bytes = 0;   // of the ll.pt and hl.pt files written
};

// Writes into `out_dir` (an existing, empty folder: a staging folder) the run `run_dir`'s
// config.yaml, checkpoint/LATEST and its checkpoint's meta.yaml (marked `policy_only: true`),
// ll.pt and hl.pt without optimiser state (and without the HL target network); the same under
// members/<m>/ for each tail member. The copy loads wherever the run does (replay, tournament,
// export, Python's load_policy) with the same actions; `train --resume` refuses it with one line.
// Throws io::InputError as load_run_policy when the run cannot be loaded.
PolicyCopyReport write_policy_copy(const std::string& run_dir, const std::string& out_dir);

}  // namespace f16race::train
