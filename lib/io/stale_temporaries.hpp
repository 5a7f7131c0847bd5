#pragma once
// Temporaries left behind by killed processes. Every temporary this program writes carries its
// writer's pid: `FILE.tmp.PID` (io::write_file_atomic), `.IMAGE.tmp.PID.N` (io::render_plot) and
// `.FOLDER.tmp.PID` (io::StagedFolder). A kill -9 leaves them; the next process that takes
// ownership of the folder removes those whose writer is gone.
#include <string>
#include <vector>

namespace f16race::io {

// The pid in a temporary's name (`*.tmp.PID` or `*.tmp.PID.N`), or 0 when `name` is not one.
long temporary_owner_pid(const std::string& name);

// Whether `pid` is a running process (a zombie counts as gone: it writes nothing any more). A
// pid we may not signal still exists, so it counts as running.
bool process_alive(long pid);

// Removes the temporaries in `dir` itself (not below it) whose writer is no longer running:
// files, and staging folders with everything in them. A live writer's temporaries are left
// alone, as is every other name. With `name_prefix`, only names starting with it are looked at.
// Returns the names removed, sorted. Errors are skipped: a temporary that stays is harmless.
std::vector<std::string> remove_stale_temporaries(const std::string& dir, const std::string& name_prefix = "");

}  // namespace f16race::io
