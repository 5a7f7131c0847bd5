#include "io/staged_folder.hpp"

#include <fcntl.h>
#include <stdio.h>  // renameat2, RENAME_EXCHANGE (glibc >= 2.28, _GNU_SOURCE)
#include <unistd.h>

#include <algorithm>
#include <cctype>
#include <cerrno>
#include <cstring>
#include <filesystem>
#include <vector>

#include "io/atomic_file.hpp"
#include "io/input_error.hpp"
#include "io/stale_temporaries.hpp"

namespace f16race::io {

namespace fs = std::filesystem;

namespace {

std::string lower_first(std::string s) {
  if (!s.empty()) s[0] = static_cast<char>(std::tolower(static_cast<unsigned char>(s[0])));
  return s;
}

std::string cause(int err) { return lower_first(std::strerror(err)); }

// fsync of one file or folder; false with errno set.
bool sync_path(const std::string& path, bool directory) {
  const int fd = ::open(path.c_str(), O_RDONLY | O_CLOEXEC | (directory ? O_DIRECTORY : 0));
  if (fd < 0) return false;
  const bool ok = ::fsync(fd) == 0;
  const int err = errno;
  ::close(fd);
  errno = err;
  return ok;
}

void replace_all(std::string& s, const std::string& from, const std::string& to) {
  for (auto at = s.find(from); !from.empty() && at != std::string::npos; at = s.find(from, at + to.size()))
    s.replace(at, from.size(), to);
}

}  // namespace

void sync_tree(const std::string& dir) {
  std::error_code ec;
  std::vector<std::pair<std::string, bool>> paths;  // files first, then their folders
  for (auto it = fs::recursive_directory_iterator(dir, ec); !ec && it != fs::recursive_directory_iterator();
       it.increment(ec)) {
    const fs::file_status st = it->symlink_status(ec);
    if (fs::is_regular_file(st)) paths.emplace_back(it->path().string(), false);
    else if (fs::is_directory(st)) paths.emplace_back(it->path().string(), true);
  }
  if (ec) throw FileWriteError(dir + ": " + lower_first(ec.message()) + " while listing it to flush to disk");
  std::stable_partition(paths.begin(), paths.end(), [](const auto& p) { return !p.second; });
  paths.emplace_back(dir, true);
  for (const auto& [path, directory] : paths)
    if (!sync_path(path, directory)) throw FileWriteError(path + ": " + cause(errno) + " while flushing to disk");
}

StagedFolder::StagedFolder(std::string final_dir, std::string what, OutputNames owns)
    : final_(std::move(final_dir)), what_(std::move(what)), owns_(std::move(owns)) {
  if (final_.empty()) throw InputError("the " + what_ + " output folder is empty text; name a folder");
  fs::path p = fs::absolute(final_).lexically_normal();
  if (!p.has_filename()) p = p.parent_path();  // "out/" names the folder out
  std::error_code ec;
  if (fs::is_symlink(p, ec)) {  // the link stays; the folder it points to is the output
    p = fs::canonical(p, ec);
    if (ec) throw InputError(final_ + ": is a link to a missing folder (" + ec.message() + "); choose another folder");
  }
  if (p == p.root_path()) throw InputError(final_ + ": is the root folder; choose another output folder");
  real_ = p.string();
  fs::create_directories(p.parent_path(), ec);
  if (ec)
    throw InputError(final_ + ": cannot create its parent folder (" + ec.message() + "); choose another output folder");
  if (fs::exists(p, ec) && !fs::is_directory(p, ec))
    throw InputError(final_ + ": is a file, not a folder; choose another output folder");
  const fs::path cwd = fs::current_path(ec);
  const fs::path here = fs::weakly_canonical(p, ec);
  if (!ec && (cwd == here || cwd.string().rfind(here.string() + "/", 0) == 0))
    throw InputError(final_ + ": holds the working folder, which a new " + what_ + " output would replace; choose another");
  check_owned();
  const std::string name = p.filename().string();
  remove_stale_temporaries(p.parent_path().string(), "." + name + ".");
  staging_ = (p.parent_path() / ("." + name + ".tmp." + std::to_string(::getpid()))).string();
  fs::remove_all(staging_, ec);  // only ever a dead process's, whose pid this one reuses
  fs::create_directory(staging_, ec);
  if (ec)
    throw InputError(final_ + ": cannot create the staging folder " + staging_ + " beside it (" + ec.message() +
                     "); choose another output folder");
}

StagedFolder::~StagedFolder() {
  if (committed_ || staging_.empty()) return;
  std::error_code ec;
  fs::remove_all(staging_, ec);
}

void StagedFolder::check_owned() const {
  std::vector<std::string> foreign;
  std::error_code ec;
  for (const auto& e : fs::directory_iterator(real_, ec)) {
    const std::string name = e.path().filename().string();
    if (owns_(name) || temporary_owner_pid(name) != 0) continue;
    std::error_code dir_ec;
    foreign.push_back(name + (e.is_directory(dir_ec) ? "/" : ""));
  }
  if (foreign.empty()) return;
  std::sort(foreign.begin(), foreign.end());
  std::string list;
  for (std::size_t k = 0; k < foreign.size() && k < 3; ++k) list += (k ? ", " : "") + foreign[k];
  if (foreign.size() > 3) list += " and " + std::to_string(foreign.size() - 3) + " more";
  throw InputError(final_ + ": holds " + list + ", not " + what_ + " output, and a new " + what_ +
                   " output replaces the whole folder; move them out or choose another output folder");
}

void StagedFolder::fail(const std::string& what_failed) const {
  throw FileWriteError(final_ + ": " + what_failed + "; " + final_ + " is unchanged, none of this " + what_ +
                       " output was kept");
}

void StagedFolder::commit(const std::function<void(const std::string& staging_dir)>& write) {
  try {
    write(staging_);
  } catch (const fs::filesystem_error& e) {
    std::string where = e.path1().string();
    replace_all(where, staging_ + "/", "");
    fail(lower_first(e.code().message()) + " while writing " + (where.empty() ? std::string("its files") : where));
  } catch (const InputError& e) {
    // The writers' messages name the file in the staging folder and speak for that file alone.
    std::string m = e.what();
    if (m.find(staging_) == std::string::npos) throw;  // not a write into the folder: as it was
    replace_all(m, staging_, final_);
    const auto tail = m.find("; nothing");
    if (tail != std::string::npos) m.erase(tail);
    throw FileWriteError(m + "; " + final_ + " is unchanged, none of this " + what_ + " output was kept");
  }
  check_owned();  // a file put there while this command ran would be deleted by the swap
  try {
    sync_tree(staging_);
  } catch (const FileWriteError& e) {
    std::string m = e.what();
    replace_all(m, staging_ + "/", "");
    replace_all(m, staging_, "the staging folder");
    fail(m);
  }
  swap_in();
}

void StagedFolder::swap_in() {
  const std::string parent = fs::path(real_).parent_path().string();
  std::error_code ec;
  for (int attempt = 0; attempt < 16; ++attempt) {
    // No earlier output: a plain move that cannot replace one made meanwhile.
    if (::renameat2(AT_FDCWD, staging_.c_str(), AT_FDCWD, real_.c_str(), RENAME_NOREPLACE) == 0) {
      committed_ = true;
      // Best effort: the swap is done, and a folder whose entry was not flushed is still whole.
      (void)sync_path(parent, true);
      return;
    }
    int err = errno;
    if (err == EEXIST || err == ENOTEMPTY) {
      if (::renameat2(AT_FDCWD, staging_.c_str(), AT_FDCWD, real_.c_str(), RENAME_EXCHANGE) == 0) {
        committed_ = true;
        (void)sync_path(parent, true);
        fs::remove_all(staging_, ec);  // the earlier output, now under the staging name
        return;
      }
      err = errno;
      if (err == ENOENT) continue;  // removed meanwhile: place the new one as above
    }
    if (err != EINVAL && err != ENOSYS) fail(cause(err) + " while moving the new output into place");
    // A filesystem without renameat2's flags: the earlier folder is moved aside, then replaced.
    // A kill between the two renames leaves no output (never a mix) and the old one aside as a
    // stale temporary.
    const std::string aside =
        parent + "/." + fs::path(real_).filename().string() + ".old.tmp." + std::to_string(::getpid());
    const bool had_old = fs::exists(real_, ec);
    if (had_old && ::rename(real_.c_str(), aside.c_str()) != 0) fail(cause(errno) + " while moving the earlier output aside");
    if (::rename(staging_.c_str(), real_.c_str()) != 0) {
      const int move_err = errno;
      if (had_old) (void)::rename(aside.c_str(), real_.c_str());
      fail(cause(move_err) + " while moving the new output into place");
    }
    committed_ = true;
    (void)sync_path(parent, true);
    if (had_old) fs::remove_all(aside, ec);
    return;
  }
  fail("another process kept replacing it while the new output was moved into place");
}

}  // namespace f16race::io
