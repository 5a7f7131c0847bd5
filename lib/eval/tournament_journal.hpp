#pragma once
// A tournament's races as they finish, appended to .OUT.journal beside the output folder OUT
// (which stays as it was until the new output is swapped in whole), so that a tournament
// stopped by a kill, a full disk or the end of a working session goes on where it stopped when
// the same command is run again, instead of racing everything anew. A race is the same race in
// any env slot and batch (its track, start and @random draws come from its own streams; greedy
// networks act per row), so the journal's races and the ones raced after it make the same
// tournament, byte for byte, as one unbroken run.
//
// File: a header line, an identity line (the build, the options and each run's checkpoint: a
// journal of any other tournament is started anew), then one line per race. A line cut short by
// a kill is dropped when the journal is read.
#include <functional>
#include <string>
#include <vector>

#include "eval/tournament.hpp"

namespace f16race::eval {

// The journal of the tournament written to `out_dir`: `.NAME.journal` in its parent folder.
std::string tournament_journal_path(const std::string& out_dir);

class TournamentJournal {
 public:
  // Locks `path` (flock, held for the object's lifetime: one tournament writes it) and keeps its
  // races when it was written for `identity` and `accept` takes every one of them (a race of this
  // tournament's games, not seen before); otherwise, and when the file is missing, starts it
  // anew. Throws io::InputError when another process holds it, io::FileWriteError when it
  // cannot be written.
  TournamentJournal(std::string path, const std::string& identity,
                    const std::function<bool(const RaceRecord&)>& accept);
  ~TournamentJournal();
  TournamentJournal(const TournamentJournal&) = delete;
  TournamentJournal& operator=(const TournamentJournal&) = delete;

  // The races kept from an earlier, stopped run of this tournament (file order).
  const std::vector<RaceRecord>& kept() const { return kept_; }
  // One line for a person: how many races were kept, or why the journal was started anew
  // (empty when there was none).
  const std::string& note() const { return note_; }

  // Appends the races, whole lines only: on a write error the file keeps what it held and
  // io::FileWriteError names it.
  void append(const std::vector<RaceRecord>& races) const;

 private:
  bool write_at_end(const std::string& bytes) const;  // whole or nothing; false with errno
  [[noreturn]] void fail(const std::string& what) const;  // io::FileWriteError naming the file, errno

  std::string path_;
  int fd_ = -1;
  std::vector<RaceRecord> kept_;
  std::string note_;
};

// One journal line (no newline) and back; parse returns false for anything but a whole line.
std::string journal_line(const RaceRecord& race);
bool parse_journal_line(const std::string& line, RaceRecord* race);

}  // namespace f16race::eval
