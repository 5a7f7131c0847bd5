#pragma once
// The one way this program writes a file: whole files atomically, logs by checked appends.
// Every write, fsync and close is checked, so a full disk or a read-only folder is one clear
// line instead of a truncated file that looks fine.
#include <stdexcept>
#include <string>
#include <string_view>

#include "io/input_error.hpp"

namespace f16race::io {

// A file could not be written; the message is one line naming the file, the cause and what
// was left untouched. The apps report it as a user error (exit 2): the disk is the user's.
class FileWriteError : public InputError {
 public:
  using InputError::InputError;
};

// Writes `bytes` to `path` through a temporary in the same folder (created with its parents),
// fsync and rename: readers see the old file or the new one, never a part. On failure the
// temporary is removed and `path` keeps its old content.
void write_file_atomic(const std::string& path, std::string_view bytes);

// Appends `bytes` to `path` (created if missing). On failure the file is cut back to its old
// length, so a log never ends in half a line.
void append_file(const std::string& path, std::string_view bytes);

// A whole file's bytes; io::InputError "PATH: cannot read" when it cannot be opened.
std::string read_file(const std::string& path);

}  // namespace f16race::io
