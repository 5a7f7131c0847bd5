#include "io/run_folder.hpp"

#include <fcntl.h>
#include <sys/file.h>
#include <unistd.h>

#include <algorithm>
#include <cerrno>
#include <cstring>
#include <filesystem>
#include <stdexcept>
#include <system_error>

#include "io/input_error.hpp"

namespace f16race::io {

namespace fs = std::filesystem;

namespace {
constexpr const char* kLockName = ".lock";

std::string holder_pid(int fd) {
  char buf[32] = {};
  const ssize_t n = pread(fd, buf, sizeof buf - 1, 0);
  std::string s = n > 0 ? std::string(buf, static_cast<std::size_t>(n)) : std::string();
  while (!s.empty() && (s.back() == '\n' || s.back() == ' ')) s.pop_back();
  return s.empty() ? std::string("unknown") : s;
}
}  // namespace

RunFolderLock::RunFolderLock(const std::string& run_dir) {
  std::error_code ec;
  fs::create_directories(run_dir, ec);
  if (ec) throw io::InputError(run_dir + ": cannot create the run folder: " + ec.message());
  const std::string path = (fs::path(run_dir) / kLockName).string();
  existed_ = fs::exists(path, ec);
  fd_ = ::open(path.c_str(), O_RDWR | O_CREAT | O_CLOEXEC, 0644);
  if (fd_ < 0) throw io::InputError(path + ": cannot open the run folder's lock: " + std::strerror(errno));
  if (::flock(fd_, LOCK_EX | LOCK_NB) != 0) {
    const int err = errno;
    const std::string pid = holder_pid(fd_);
    ::close(fd_);
    fd_ = -1;
    if (err == EWOULDBLOCK)
      throw io::InputError(run_dir + " is in use by another f16race train (pid " + pid +
                               "); wait for it to end or stop it, or choose another --run folder");
    throw io::InputError(path + ": cannot lock the run folder: " + std::strerror(err));
  }
  char buf[64];
  const ssize_t n = ::pread(fd_, buf, sizeof buf, 0);
  found_.assign(buf, n > 0 ? static_cast<std::size_t>(n) : 0);
  // Who holds it, for the message above; the lock itself is the flock, not this text.
  const std::string pid = std::to_string(::getpid()) + "\n";
  // Unchecked on purpose: without the pid the lock still works, and a full disk is reported by
  // the first real write.
  if (::ftruncate(fd_, 0) == 0) (void)!::pwrite(fd_, pid.data(), pid.size(), 0);
}

void RunFolderLock::release() {
  if (fd_ < 0) return;
  // Still held: no other process writes the file. One this lock created stays, empty: unlinking it
  // could hand a process that opened it meanwhile a lock on a file no one else sees.
  if (!claimed_ && ::ftruncate(fd_, 0) == 0 && existed_) (void)!::pwrite(fd_, found_.data(), found_.size(), 0);
  ::close(fd_);  // releases the flock
  fd_ = -1;
}

RunFolderLock::~RunFolderLock() { release(); }

RunFolderLock::RunFolderLock(RunFolderLock&& other) noexcept
    : fd_(other.fd_), claimed_(other.claimed_), existed_(other.existed_), found_(std::move(other.found_)) {
  other.fd_ = -1;
}

RunFolderLock& RunFolderLock::operator=(RunFolderLock&& other) noexcept {
  if (this != &other) {
    release();
    fd_ = other.fd_;
    claimed_ = other.claimed_;
    existed_ = other.existed_;
    found_ = std::move(other.found_);
    other.fd_ = -1;
  }
  return *this;
}

std::string run_folder_holder(const std::string& run_dir) {
  const std::string path = (fs::path(run_dir) / kLockName).string();
  const int fd = ::open(path.c_str(), O_RDONLY | O_CLOEXEC);
  if (fd < 0) return "";
  std::string holder;
  if (::flock(fd, LOCK_EX | LOCK_NB) != 0) holder = errno == EWOULDBLOCK ? holder_pid(fd) : "";
  ::close(fd);  // releases the probe's lock, if it took it
  return holder;
}

std::vector<std::string> run_data_in(const std::string& run_dir) {
  std::vector<std::string> out;
  std::error_code ec;
  if (!fs::is_directory(run_dir, ec)) return out;
  for (const auto& entry : fs::directory_iterator(run_dir, ec)) {
    const std::string name = entry.path().filename().string();
    if (name == kLockName) continue;
    // The empty folders a fresh run creates first hold nothing to lose.
    if (entry.is_directory(ec) && fs::is_empty(entry.path(), ec)) continue;
    out.push_back(name);
  }
  if (ec) throw io::InputError(run_dir + ": cannot list the run folder: " + ec.message());
  std::sort(out.begin(), out.end());
  return out;
}

std::string move_run_aside(const std::string& run_dir) {
  std::string base = fs::path(run_dir).lexically_normal().string();
  while (base.size() > 1 && base.back() == '/') base.pop_back();
  for (int n = 1; n < 100000; ++n) {
    const std::string aside = base + ".old-" + std::to_string(n);
    std::error_code ec;
    if (fs::exists(aside, ec)) continue;
    fs::rename(base, aside, ec);
    if (ec) throw io::InputError(run_dir + ": cannot move the old run aside to " + aside + ": " + ec.message());
    return aside;
  }
  throw io::InputError(run_dir + ": no free name " + base + ".old-N to move the old run aside to");
}

}  // namespace f16race::io
