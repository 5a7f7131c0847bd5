#pragma once
// An input the user can fix, found when it is used: a run folder (missing, locked, holding a
// run), a checkpoint (missing, corrupt, from another config), runs that cannot race together, a
// tournament or replay request that names nothing to do. The message is one line naming the file
// or option and the fix; the apps exit 2 with it. Anything else that escapes a command is a bug
// and is reported as an internal error (exit 1), so the two are never confused. The
// more specific user errors (io::ConfigError, io::CsvError, io::FileWriteError) derive from it,
// so `catch (const io::InputError&)` is the one place the apps tell the two kinds apart.
#include <stdexcept>

namespace f16race::io {

class InputError : public std::runtime_error {
 public:
  using std::runtime_error::runtime_error;
};

}  // namespace f16race::io
