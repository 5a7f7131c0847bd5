#pragma once
// The numeric mode a run was trained in (io/numeric_mode.hpp), as each checkpoint's meta.yaml
// records it: `numerics: reproducible`, or `numerics: native` with the `cpu:` it ran on. In the
// checkpoint, not beside it, so the record is as durable as what it describes: a run killed before
// its first checkpoint starts afresh in whatever mode resumes it, and tail members and policy
// copies carry their checkpoint's record.
#include <string>

#include "io/numeric_mode.hpp"

namespace f16race::train {

// The lines this process adds to a checkpoint's meta.yaml.
std::string numerics_meta_lines();

// The record in CHECKPOINT_DIR/meta.yaml (not recorded: a checkpoint from before the record).
// Throws io::InputError naming the file when the record is there but names no known mode.
io::RunNumerics checkpoint_numerics(const std::string& checkpoint_dir);

// The record of RUN's LATEST checkpoint; not recorded when the run has none yet.
io::RunNumerics run_numerics(const std::string& run_dir);

// Resuming RUN from its LATEST checkpoint in this process: a run of the other mode is refused
// (io::InputError, one line with the fix); a native run resumed natively on another CPU is said
// in a warning on stderr and goes on (its bytes from there on are this CPU's).
void check_resume_numerics(const std::string& run_dir);

}  // namespace f16race::train
