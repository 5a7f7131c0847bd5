#include "eval/study_runner.hpp"

#include <omp.h>
#include <sys/wait.h>
#include <unistd.h>

#include <algorithm>
#include <chrono>
#include <csignal>
#include <cstdarg>
#include <cstdio>
#include <filesystem>
#include <fstream>
#include <thread>

#include "eval/study_report.hpp"
#include "eval/tournament.hpp"
#include "eval/tournament_output.hpp"
#include "io/atomic_file.hpp"
#include "io/child_process.hpp"
#include "io/input_error.hpp"
#include "io/plot.hpp"
#include "io/run_folder.hpp"
#include "io/stale_temporaries.hpp"

namespace f16race::eval {
namespace {

namespace fs = std::filesystem;
using Clock = std::chrono::steady_clock;

// printf into a string, any length (the progress line names every running cell).
std::string format(const char* fmt, ...) __attribute__((format(printf, 1, 2)));
std::string format(const char* fmt, ...) {
  va_list args, again;
  va_start(args, fmt);
  va_copy(again, args);
  const int n = std::vsnprintf(nullptr, 0, fmt, args);
  va_end(args);
  std::string s(static_cast<std::size_t>(n > 0 ? n : 0) + 1, '\0');
  std::vsnprintf(s.data(), s.size(), fmt, again);
  va_end(again);
  s.pop_back();
  return s;
}

pid_t spawn_f16race(const StudyRun& run, const std::vector<std::string>& args, const std::string& log_path) {
  std::vector<std::string> argv{run.executable};
  argv.insert(argv.end(), args.begin(), args.end());
  return io::spawn_child(argv, log_path);
}

// Waits until no process holds the run folders of `cells` (a training of an earlier study that
// was killed: its SIGTERM from PR_SET_PDEATHSIG makes it checkpoint and stop), at most `limit`.
void wait_for_run_folders(const StudyRun& run, const std::vector<StudyCell>& cells, std::chrono::seconds limit) {
  const auto until = Clock::now() + limit;
  for (const auto& c : cells) {
    bool said = false;
    for (std::string pid = io::run_folder_holder(c.run_dir); !pid.empty(); pid = io::run_folder_holder(c.run_dir)) {
      if (*run.stop) return;
      if (Clock::now() >= until)
        throw io::InputError(c.run_dir + " is in use by another f16race train (pid " + pid +
                             "); stop it, then run the study again");
      if (!said) run.say(format("study: waiting for pid %s, a training still holding %s, to stop\n", pid.c_str(), c.run_dir.c_str()));
      said = true;
      std::this_thread::sleep_for(std::chrono::milliseconds(200));
    }
  }
}

// The trainings of one interval's cells, `jobs` at a time. After a stop or a failed cell nothing
// new starts; the running ones are waited for.
class CellTrainer {
 public:
  CellTrainer(const StudyRun& run, const std::vector<StudyCell>& cells) : run_(run), cfg_(run.config), cells_(cells) {}

  // False when stopped; io::InputError naming the first failed cell.
  bool train() {
    wait_for_run_folders(run_, cells_, std::chrono::seconds(120));
    for (const auto& c : cells_) status_.push_back(cell_status(cfg_, c));
    for (std::size_t i = 0; i < cells_.size(); ++i)
      if (status_[i].state != CellState::finished) todo_.push_back(i);
    finished_ = cells_.size() - todo_.size();
    run_.say(format("study: %zu cells, %zu finished, %zu to train (%d at a time); logs in %s/logs\n", cells_.size(),
                    finished_, todo_.size(), cfg_.jobs, run_.out.c_str()));
    fs::create_directories(fs::path(run_.out) / "logs");
    auto last_print = Clock::now() - std::chrono::seconds(60);
    while ((may_start() && next_ < todo_.size()) || !running_.empty()) {
      start_cells();
      reap_cells();
      if (*run_.stop && !signalled_) {
        signalled_ = true;
        for (const auto& r : running_) kill(r.pid, SIGINT);  // each checkpoints and exits 130
      }
      const auto now = Clock::now();
      if (!running_.empty() && now - last_print >= std::chrono::seconds(30)) {
        last_print = now;
        report_progress(now);
      }
      std::this_thread::sleep_for(std::chrono::milliseconds(200));
    }
    if (!failure_.empty()) throw io::InputError(failure_);
    return !*run_.stop;
  }

 private:
  struct Running {
    std::size_t cell = 0;
    pid_t pid = 0;
    Clock::time_point start;
    std::int64_t work_at_start = 0;
  };

  bool may_start() const { return !*run_.stop && failure_.empty(); }

  // A cell not started yet; a fresh one's folder may hold a leftover that `train --overwrite`
  // moves aside, so none of it counts.
  CellWork queued_work(std::size_t i) const {
    CellWork w = cell_work(status_[i], cells_[i].run_dir);
    if (status_[i].state == CellState::fresh) w.done = 0;
    return w;
  }

  void start_cells() {
    while (may_start() && next_ < todo_.size() && static_cast<int>(running_.size()) < cfg_.jobs) {
      const std::size_t i = todo_[next_++];
      const auto& c = cells_[i];
      fs::create_directories(fs::path(c.run_dir).parent_path());
      const std::string log = (fs::path(run_.out) / "logs" / (interval_name(c.dt_hl_s) + "_" + c.variant + "_s" +
                                                              std::to_string(c.seed) + ".log")).string();
      running_.push_back({i, spawn_f16race(run_, cell_train_args(cfg_, c, status_[i].state), log), Clock::now(),
                          queued_work(i).done});
      run_.say(format("study: %s %s (%s)\n", status_[i].state == CellState::partial ? "resuming" : "training",
                      cell_label(c).c_str(), log.c_str()));
    }
  }

  void reap_cells() {
    for (std::size_t k = 0; k < running_.size();) {
      int ws = 0;
      const pid_t r = waitpid(running_[k].pid, &ws, WNOHANG);
      if (r != running_[k].pid) {
        ++k;
        continue;
      }
      const auto& c = cells_[running_[k].cell];
      const int code = io::exit_code(ws);
      if (code == 0) {
        ++finished_;
        run_.say(format("study: %s finished (%zu of %zu cells)\n", cell_label(c).c_str(), finished_, cells_.size()));
      } else if (!(*run_.stop && code == 130) && failure_.empty()) {
        failure_ = cell_label(c) + ": training exited with status " + std::to_string(code) + "; see " + run_.out +
                   "/logs; fix it and run the study again (finished cells are kept)";
      }
      running_.erase(running_.begin() + static_cast<std::ptrdiff_t>(k));
    }
  }

  void report_progress(Clock::time_point now) {
    std::vector<CellProgress> progress;
    for (const auto& r : running_) {
      const auto& c = cells_[r.cell];
      const CellWork w = cell_work(status_[r.cell], c.run_dir);
      progress.push_back({cell_label(c), w.done, r.work_at_start, w.total,
                          std::chrono::duration<double>(now - r.start).count()});
    }
    double queued_left = 0.0;
    for (std::size_t q = next_; q < todo_.size(); ++q) {
      const CellWork w = queued_work(todo_[q]);
      queued_left += static_cast<double>(w.total - w.done);
    }
    run_.say(study_progress_line(finished_, cells_.size(), progress, queued_left));
  }

  const StudyRun& run_;
  const StudyConfig& cfg_;
  const std::vector<StudyCell>& cells_;
  std::vector<CellStatus> status_;
  std::vector<std::size_t> todo_;
  std::vector<Running> running_;
  std::size_t next_ = 0, finished_ = 0;
  std::string failure_;
  bool signalled_ = false;
};

// Races one interval's tournament as a child `f16race tournament` (logged like the trainings),
// which writes its folder whole. Returns false when the study was stopped.
bool race_interval(const StudyRun& run, const TournamentOptions& t, double dt) {
  const std::string name = interval_name(dt);
  const std::string log = (fs::path(run.out) / "logs" / (name + "_tournament.log")).string();
  std::vector<std::string> args{"--threads", std::to_string(omp_get_max_threads())};
  for (const std::string& a : tournament_args(t)) args.push_back(a);
  const pid_t pid = spawn_f16race(run, args, log);
  int ws = 0;
  bool signalled = false;
  while (waitpid(pid, &ws, WNOHANG) != pid) {
    if (*run.stop && !signalled) {
      signalled = true;
      kill(pid, SIGINT);
    }
    std::this_thread::sleep_for(std::chrono::milliseconds(200));
  }
  if (*run.stop) return false;
  const int code = io::exit_code(ws);
  if (code != 0)
    throw io::InputError(name + " tournament: exited with status " + std::to_string(code) + "; see " + log +
                         ", fix it and run the study again (trained runs are kept)");
  std::string why;
  if (!tournament_complete(t, &why))
    throw io::InputError(name + " tournament: not complete in " + t.out_dir + " (" + why + "); see " + log +
                         ", fix it and run the study again, which races it again");
  return true;
}

// The study folder and its interval folders: created, and cleared of the temporaries of killed
// processes (a staging folder of a tournament or report, a study.yaml.tmp.PID); the study config
// as run written next to its results.
void own_study_folder(const StudyRun& run) {
  fs::create_directories(run.out);
  std::vector<std::string> removed = io::remove_stale_temporaries(run.out);
  for (double dt : run.config.dt_hl_s) {
    const std::string dir = interval_dir(run.out, dt);
    fs::create_directories(dir);
    for (const std::string& r : io::remove_stale_temporaries(dir)) removed.push_back(r);
  }
  if (!removed.empty())
    run.say(format("study: removed %zu temporaries left by stopped processes in %s\n", removed.size(), run.out.c_str()));
  std::ifstream in(run.config_path);
  io::write_file_atomic((fs::path(run.out) / "study.yaml").string(), std::string((std::istreambuf_iterator<char>(in)), {}));
}

// One interval: its runs, then its tournament and the report so far. False when stopped.
bool run_interval(const StudyRun& run, double dt, double* tournament_s) {
  const StudyConfig& cfg = run.config;
  const std::string name = interval_name(dt);
  std::vector<StudyCell> interval_cells;
  for (const auto& c : run.cells)
    if (interval_name(c.dt_hl_s) == name) interval_cells.push_back(c);
  run.say(format("study: %s\n", name.c_str()));
  if (!CellTrainer(run, interval_cells).train()) {
    run.say("study: stopped; every run kept its checkpoint. Run the same command again to continue.\n");
    return false;
  }
  const TournamentOptions t = interval_tournament(cfg, run.cells, dt, run.out);
  if (tournament_complete(t)) {
    run.say(format("study: %s tournament already written (delete %s to race it again)\n", name.c_str(), t.out_dir.c_str()));
    return true;
  }
  run.say(format("study: %s tournament, %zu runs%s, %d races per pair (%s/logs/%s_tournament.log)\n", name.c_str(),
                 t.runs.size(), cfg.controls ? " with controls" : "", cfg.races_per_pair, run.out.c_str(), name.c_str()));
  const auto t0 = Clock::now();
  if (!race_interval(run, t, dt)) {
    run.say(format("study: stopped during the %s tournament; run the same command again to race it.\n", name.c_str()));
    return false;
  }
  *tournament_s += std::chrono::duration<double>(Clock::now() - t0).count();
  write_study_report(cfg, run.cells, run.out, run.config_path, *tournament_s);
  run.say(format("study: %s done; report so far in %s\n", name.c_str(),
                 (fs::path(run.out) / "report" / "report.md").string().c_str()));
  return true;
}

}  // namespace

std::string cell_label(const StudyCell& c) {
  return interval_name(c.dt_hl_s) + "/" + c.variant + "_s" + std::to_string(c.seed);
}

const char* cell_state_name(CellState s) {
  switch (s) {
    case CellState::fresh: return "to train";
    case CellState::partial: return "to resume";
    case CellState::finished: return "finished";
  }
  return "?";
}

std::string hms(double s) {
  if (!(s >= 0.0) || s > 1e7) return "?";
  const long t = static_cast<long>(s + 0.5);
  char buf[32];
  if (t >= 3600) std::snprintf(buf, sizeof buf, "%ldh%02ldm", t / 3600, t / 60 % 60);
  else std::snprintf(buf, sizeof buf, "%ldm%02lds", t / 60, t % 60);
  return buf;
}

std::string study_progress_line(std::size_t finished, std::size_t n_cells, const std::vector<CellProgress>& running,
                                double queued_steps_left) {
  double rate_sum = 0.0, left = queued_steps_left;
  std::string line;
  for (const CellProgress& r : running) {
    const double el = r.elapsed_s, to_go = static_cast<double>(std::max<std::int64_t>(0, r.work_total - r.work_done));
    const double rate = el > 0 && r.work_done > r.work_at_start ? (r.work_done - r.work_at_start) / el : 0.0;
    rate_sum += rate;
    left += to_go;
    const double frac = r.work_total > 0 ? static_cast<double>(r.work_done) / static_cast<double>(r.work_total) : 0.0;
    line += " | " + r.label + " " + std::to_string(static_cast<int>(100 * frac)) + "% ETA " +
            (rate > 0 ? hms(to_go / rate) : std::string("?"));
  }
  return format("study: %zu/%zu cells done%s | study ETA %s (trainings)\n", finished, n_cells, line.c_str(),
                rate_sum > 0 ? hms(left / rate_sum).c_str() : "?");
}

bool run_study(const StudyRun& run) {
  // An interval's tournament is done only with its figures: found now, not after hours of training.
  if (!io::gnuplot_available())
    throw io::InputError("study: gnuplot not found; the study's figures need it: install gnuplot-nox, then run it again");
  own_study_folder(run);
  // One interval at a time, so a study cut short (a session's end) has its first horizon
  // finished instead of every run half done.
  double tournament_s = 0.0;
  for (double dt : run.config.dt_hl_s)
    if (!run_interval(run, dt, &tournament_s)) return false;
  write_study_report(run.config, run.cells, run.out, run.config_path, tournament_s);
  run.say(format("study: done; report in %s\n", (fs::path(run.out) / "report" / "report.md").string().c_str()));
  return true;
}

}  // namespace f16race::eval
