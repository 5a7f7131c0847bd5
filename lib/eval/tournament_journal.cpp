#include "eval/tournament_journal.hpp"

#include <fcntl.h>
#include <sys/file.h>
#include <unistd.h>

#include <cctype>
#include <cerrno>
#include <cstdio>
#include <cstring>
#include <cstdlib>
#include <filesystem>
#include <iterator>
#include <sstream>
#include <system_error>

#include "io/atomic_file.hpp"

namespace f16race::eval {

namespace fs = std::filesystem;

namespace {

// "no space left on device": strerror in the lower case of the program's other messages.
std::string cause(int err) {
  std::string c = std::strerror(err);
  if (!c.empty()) c[0] = static_cast<char>(std::tolower(static_cast<unsigned char>(c[0])));
  return c;
}

constexpr const char* kJournalHeader = "f16race tournament journal 2: the races raced so far, one per line";

// The identity on one line whatever it holds.
std::string one_line(std::string s) {
  for (char& c : s)
    if (c == '\n' || c == '\r') c = ' ';
  return s;
}

// The races of `text` after `head`, whole lines only, each taken by `accept`. Returns "" and
// fills `kept` and `whole_bytes` (where the last whole line ends), or why the journal is not
// this tournament's.
std::string read_races(const std::string& text, const std::string& head,
                       const std::function<bool(const RaceRecord&)>& accept, std::vector<RaceRecord>* kept,
                       std::size_t* whole_bytes) {
  if (text.compare(0, head.size(), head) != 0)
    return "it was written for another tournament (other runs, checkpoints, options or build)";
  std::size_t at = head.size();
  for (long line = 3;; ++line) {
    const std::size_t end = text.find('\n', at);
    if (end == std::string::npos) break;  // the rest, if any, is a line cut short by a kill
    RaceRecord r;
    if (!parse_journal_line(text.substr(at, end - at), &r) || !accept(r))
      return "line " + std::to_string(line) + " is not a race of this tournament";
    kept->push_back(r);
    at = end + 1;
  }
  *whole_bytes = at;
  return "";
}

}  // namespace

std::string tournament_journal_path(const std::string& out_dir) {
  fs::path out = fs::path(out_dir).lexically_normal();
  if (!out.has_filename()) out = out.parent_path();  // "runs/t/"
  return (out.parent_path() / ("." + out.filename().string() + ".journal")).string();
}

std::string journal_line(const RaceRecord& r) {
  std::ostringstream s;
  char duration[40];
  std::snprintf(duration, sizeof duration, "%.17g", r.duration_s);  // 17 digits: the same double back
  s << r.pair << ' ' << r.race << ' ' << r.blue << ' ' << r.red << ' ' << r.track << ' ' << r.env << ' ' << r.winner
    << ' ' << r.end_reason << ' ' << duration << ' ' << r.blue_blocks << ' ' << r.red_blocks;
  for (int c : r.blue_lost) s << ' ' << c;
  for (int c : r.red_lost) s << ' ' << c;
  for (int c : r.blue_choices) s << ' ' << c;
  for (int c : r.red_choices) s << ' ' << c;
  return s.str();
}

bool parse_journal_line(const std::string& line, RaceRecord* r) {
  std::istringstream s(line);
  std::string duration;
  s >> r->pair >> r->race >> r->blue >> r->red >> r->track >> r->env >> r->winner >> r->end_reason >> duration >>
      r->blue_blocks >> r->red_blocks;
  for (int& c : r->blue_lost) s >> c;
  for (int& c : r->red_lost) s >> c;
  for (int& c : r->blue_choices) s >> c;
  for (int& c : r->red_choices) s >> c;
  if (!s || !(s >> std::ws).eof()) return false;
  char* end = nullptr;
  r->duration_s = std::strtod(duration.c_str(), &end);
  return end != duration.c_str() && *end == '\0';
}

TournamentJournal::TournamentJournal(std::string path, const std::string& identity,
                                     const std::function<bool(const RaceRecord&)>& accept)
    : path_(std::move(path)) {
  fd_ = ::open(path_.c_str(), O_RDWR | O_CREAT | O_CLOEXEC, 0644);
  if (fd_ < 0) throw io::FileWriteError(path_ + ": " + cause(errno) + " while opening the tournament's journal");
  if (::flock(fd_, LOCK_EX | LOCK_NB) != 0) {
    const int err = errno;
    ::close(fd_);
    fd_ = -1;
    if (err == EWOULDBLOCK)
      throw io::InputError(path_ + " is held by another f16race tournament writing to the same --out; wait for it to "
                           "end or choose another --out");
    throw io::FileWriteError(path_ + ": " + cause(err) + " while locking the tournament's journal");
  }
  const std::string head = std::string(kJournalHeader) + "\nidentity: " + one_line(identity) + "\n";
  const std::string text = io::read_file(path_);
  std::size_t whole = 0;
  const std::string why = text.empty() ? "" : read_races(text, head, accept, &kept_, &whole);
  if (!text.empty() && why.empty()) {
    note_ = "resuming: " + std::to_string(kept_.size()) + " races kept from " + path_;
    if (whole < text.size()) note_ += " (a line cut short by the stop dropped)";
    if (::ftruncate(fd_, static_cast<off_t>(whole)) != 0) fail("while dropping a line cut short");
    return;
  }
  kept_.clear();
  if (!text.empty()) note_ = path_ + ": " + why + "; racing every game anew";
  // Not a rename: the lock belongs to this file. A kill mid-header leaves a header that matches
  // nothing, so the next run starts anew too.
  if (::ftruncate(fd_, 0) != 0 || !write_at_end(head)) {
    const int err = errno;
    ::unlink(path_.c_str());  // it held nothing of this tournament; leave no empty file behind
    throw io::FileWriteError(path_ + ": " + cause(err) +
                             " while starting the tournament's journal; nothing was raced, the output folder is as it was");
  }
}

TournamentJournal::~TournamentJournal() {
  if (fd_ >= 0) ::close(fd_);  // releases the lock
}

bool TournamentJournal::write_at_end(const std::string& bytes) const {
  const off_t end = ::lseek(fd_, 0, SEEK_END);
  if (end < 0) return false;
  for (std::size_t at = 0; at < bytes.size();) {
    const ssize_t n = ::write(fd_, bytes.data() + at, bytes.size() - at);
    if (n < 0 && errno == EINTR) continue;
    if (n <= 0) {
      const int err = errno;
      (void)!::ftruncate(fd_, end);  // whole lines only; can fail too, the reader drops a part line
      errno = err;
      return false;
    }
    at += static_cast<std::size_t>(n);
  }
  return true;
}

void TournamentJournal::fail(const std::string& what) const {
  throw io::FileWriteError(path_ + ": " + cause(errno) + " " + what +
                           "; the races it holds are kept: free the space and run the same command again");
}

void TournamentJournal::append(const std::vector<RaceRecord>& races) const {
  if (races.empty()) return;
  std::string text;
  for (const RaceRecord& r : races) text += journal_line(r) + "\n";
  if (!write_at_end(text)) fail("while appending races");
}

}  // namespace f16race::eval
