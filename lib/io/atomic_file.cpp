#include "io/atomic_file.hpp"

#include <fcntl.h>
#include <sys/stat.h>
#include <unistd.h>

#include <cctype>
#include <cerrno>
#include <cstring>
#include <filesystem>
#include <fstream>
#include <sstream>

namespace f16race::io {

namespace {

namespace fs = std::filesystem;

// "no space left on device" reads better in a sentence than strerror's capitalised form.
std::string cause(int err) {
  std::string s = std::strerror(err);
  if (!s.empty()) s[0] = static_cast<char>(std::tolower(static_cast<unsigned char>(s[0])));
  return s;
}

// Writes all of `bytes`; false with errno set on failure (EINTR retried).
bool write_all(int fd, std::string_view bytes) {
  const char* p = bytes.data();
  std::size_t left = bytes.size();
  while (left > 0) {
    const ssize_t n = ::write(fd, p, left);
    if (n < 0) {
      if (errno == EINTR) continue;
      return false;
    }
    p += n;
    left -= static_cast<std::size_t>(n);
  }
  return true;
}

}  // namespace

void write_file_atomic(const std::string& path, std::string_view bytes) {
  const fs::path target(path);
  if (target.has_parent_path()) {
    std::error_code ec;
    fs::create_directories(target.parent_path(), ec);
    if (ec)
      throw FileWriteError(path + ": cannot create its folder (" + ec.message() + "); nothing was changed");
  }
  // Same folder, so rename() is atomic; the pid keeps two processes' temporaries apart.
  const std::string tmp = path + ".tmp." + std::to_string(::getpid());
  int fd = ::open(tmp.c_str(), O_WRONLY | O_CREAT | O_TRUNC | O_CLOEXEC, 0644);
  if (fd < 0)
    throw FileWriteError(path + ": " + cause(errno) + " while creating a temporary; nothing was changed");
  auto fail = [&](const char* stage) {
    const int err = errno;
    if (fd >= 0) ::close(fd);
    ::unlink(tmp.c_str());
    throw FileWriteError(path + ": " + cause(err) + " while " + stage + "; nothing else was changed");
  };
  if (!write_all(fd, bytes)) fail("writing");
  if (::fsync(fd) != 0) fail("flushing to disk");
  const int closed = ::close(fd);
  fd = -1;
  if (closed != 0) fail("closing");
  if (::rename(tmp.c_str(), path.c_str()) != 0) fail("replacing the old file");
}

void append_file(const std::string& path, std::string_view bytes) {
  const int fd = ::open(path.c_str(), O_WRONLY | O_CREAT | O_APPEND | O_CLOEXEC, 0644);
  if (fd < 0) throw FileWriteError(path + ": " + cause(errno) + " while opening to append; nothing was changed");
  struct stat st {};
  const off_t old_size = ::fstat(fd, &st) == 0 ? st.st_size : -1;
  if (!write_all(fd, bytes)) {
    const int err = errno;
    // Cutting back can fail too (the device went away); the message below holds either way.
    if (old_size >= 0) (void)!::ftruncate(fd, old_size);
    ::close(fd);
    throw FileWriteError(path + ": " + cause(err) + " while appending; the file keeps what it held before");
  }
  if (::close(fd) != 0)
    throw FileWriteError(path + ": " + cause(errno) + " while closing after an append");
}

std::string read_file(const std::string& path) {
  std::ifstream f(path, std::ios::binary);
  if (!f) throw InputError(path + ": cannot read");
  std::stringstream ss;
  ss << f.rdbuf();
  return ss.str();
}

}  // namespace f16race::io
