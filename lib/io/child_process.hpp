#pragma once
// Child processes that must not outlive their parent: the study's `train` and `tournament`.
// Each runs in its own process group (a terminal's Ctrl-C reaches the parent alone, which
// forwards it once and waits) and is sent SIGTERM by the kernel when its parent dies, kill -9
// included (PR_SET_PDEATHSIG), so an orphan never keeps a run folder locked.
#include <sys/types.h>

#include <string>
#include <vector>

namespace f16race::io {

// Starts argv[0] with `argv` (argv[0] included), stdout and stderr appended to `log_path`.
// Throws io::InputError when the log cannot be opened (a full disk, a read-only folder) and
// std::runtime_error when the program cannot be started, each naming the cause.
pid_t spawn_child(const std::vector<std::string>& argv, const std::string& log_path);

// A wait status as a shell reports it: the exit code, or 128 + the signal that ended it.
int exit_code(int wait_status);

}  // namespace f16race::io
