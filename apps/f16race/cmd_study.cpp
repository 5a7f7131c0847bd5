// `f16race study`: the Fig. 3 study in pieces. Trains every cell of a study config that is not
// finished (a partial run resumes from its checkpoint), `jobs` at a time as child `f16race train`
// processes of one thread each, one HL interval at a time: its runs, then its tournament, then
// OUT/report/ with every interval raced so far. Interrupt it at any time (Ctrl-C or SIGTERM is
// forwarded to the children: a training checkpoints and stops, a tournament stops; the study
// waits for them and exits 130) and run the same command again to continue. The children die
// with the study (PR_SET_PDEATHSIG), so even a kill -9 leaves no training holding a run folder.
#include <omp.h>
#include <sys/wait.h>
#include <unistd.h>

#include <CLI/CLI.hpp>
#include <atomic>
#include <chrono>
#include <csignal>
#include <cstdio>
#include <filesystem>
#include <fstream>
#include <memory>
#include <string>
#include <thread>
#include <vector>

#include "commands.hpp"
#include "eval/study.hpp"
#include "eval/study_report.hpp"
#include "eval/tournament.hpp"
#include "eval/tournament_output.hpp"
#include "io/atomic_file.hpp"
#include "io/child_process.hpp"
#include "io/input_error.hpp"
#include "io/plot.hpp"
#include "io/run_folder.hpp"
#include "io/stale_temporaries.hpp"

namespace f16race::app {
namespace {

namespace fs = std::filesystem;
using Clock = std::chrono::steady_clock;

struct StudyOptions {
  std::string config = "configs/study.yaml";
  std::string out = "runs/study";
  bool plan_only = false;
};

std::atomic<bool> g_stop{false};
void on_signal(int) { g_stop = true; }

const char* state_name(eval::CellState s) {
  switch (s) {
    case eval::CellState::fresh: return "to train";
    case eval::CellState::partial: return "to resume";
    case eval::CellState::finished: return "finished";
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

std::int64_t last_env_steps(const std::string& run_dir) {
  return static_cast<std::int64_t>(eval::last_metrics_value(run_dir, eval::kMetricsEnvStepsColumn));
}

std::string cell_label(const eval::StudyCell& c) {
  return eval::interval_name(c.dt_hl_s) + "/" + c.variant + "_s" + std::to_string(c.seed);
}

struct Running {
  std::size_t cell = 0;
  pid_t pid = 0;
  Clock::time_point start;
  std::int64_t steps_at_start = 0;
};

pid_t spawn_f16race(const std::vector<std::string>& args, const std::string& log_path) {
  std::vector<std::string> argv{"/proc/self/exe"};  // this very binary, even if rebuilt meanwhile
  argv.insert(argv.end(), args.begin(), args.end());
  return io::spawn_child(argv, log_path);
}

// Waits until no process holds the run folders of `cells` (a training of an earlier study that
// was killed: its SIGTERM from PR_SET_PDEATHSIG makes it checkpoint and stop), at most `limit`.
void wait_for_run_folders(const std::vector<eval::StudyCell>& cells, std::chrono::seconds limit) {
  const auto until = Clock::now() + limit;
  for (const auto& c : cells) {
    bool said = false;
    for (std::string pid = io::run_folder_holder(c.run_dir); !pid.empty(); pid = io::run_folder_holder(c.run_dir)) {
      if (g_stop) return;
      if (Clock::now() >= until)
        throw io::InputError(c.run_dir + " is in use by another f16race train (pid " + pid +
                             "); stop it, then run the study again");
      if (!said) std::printf("study: waiting for pid %s, a training still holding %s, to stop\n", pid.c_str(), c.run_dir.c_str());
      std::fflush(stdout);
      said = true;
      std::this_thread::sleep_for(std::chrono::milliseconds(200));
    }
  }
}

// Trains the unfinished cells; returns false when stopped by a signal.
bool train_cells(const eval::StudyConfig& cfg, const std::vector<eval::StudyCell>& cells, const std::string& out) {
  wait_for_run_folders(cells, std::chrono::seconds(120));
  std::vector<eval::CellStatus> status;
  for (const auto& c : cells) status.push_back(eval::cell_status(cfg, c));
  std::vector<std::size_t> todo;
  for (std::size_t i = 0; i < cells.size(); ++i)
    if (status[i].state != eval::CellState::finished) todo.push_back(i);
  const std::size_t n_done_before = cells.size() - todo.size();
  std::printf("study: %zu cells, %zu finished, %zu to train (%d at a time); logs in %s/logs\n", cells.size(),
              n_done_before, todo.size(), cfg.jobs, out.c_str());
  std::fflush(stdout);
  fs::create_directories(fs::path(out) / "logs");
  std::vector<Running> running;
  std::size_t next = 0, finished = n_done_before;
  std::string failure;
  bool signalled = false;
  auto last_print = Clock::now() - std::chrono::seconds(60);
  // After a signal or a failed cell nothing new starts; the running ones are waited for.
  while ((!g_stop && failure.empty() && next < todo.size()) || !running.empty()) {
    while (!g_stop && failure.empty() && next < todo.size() && static_cast<int>(running.size()) < cfg.jobs) {
      const std::size_t i = todo[next++];
      const auto& c = cells[i];
      fs::create_directories(fs::path(c.run_dir).parent_path());
      const std::string log = (fs::path(out) / "logs" / (eval::interval_name(c.dt_hl_s) + "_" + c.variant + "_s" +
                                                        std::to_string(c.seed) + ".log")).string();
      running.push_back({i, spawn_f16race(eval::cell_train_args(cfg, c, status[i].state), log), Clock::now(),
                         status[i].env_steps});
      std::printf("study: %s %s (%s)\n", status[i].state == eval::CellState::partial ? "resuming" : "training",
                  cell_label(c).c_str(), log.c_str());
      std::fflush(stdout);
    }
    // Reap finished children.
    for (std::size_t k = 0; k < running.size();) {
      int ws = 0;
      const pid_t r = waitpid(running[k].pid, &ws, WNOHANG);
      if (r == running[k].pid) {
        const auto& c = cells[running[k].cell];
        const int code = io::exit_code(ws);
        if (code == 0) {
          ++finished;
          std::printf("study: %s finished (%zu of %zu cells)\n", cell_label(c).c_str(), finished, cells.size());
        } else if (!(g_stop && code == 130) && failure.empty()) {
          failure = cell_label(c) + ": training exited with status " + std::to_string(code) + "; see " + out +
                    "/logs; fix it and run the study again (finished cells are kept)";
        }
        std::fflush(stdout);
        running.erase(running.begin() + static_cast<std::ptrdiff_t>(k));
      } else {
        ++k;
      }
    }
    if (g_stop && !signalled) {
      signalled = true;
      for (const auto& r : running) kill(r.pid, SIGINT);  // each checkpoints and exits 130
    }
    const auto now = Clock::now();
    if (!running.empty() && now - last_print >= std::chrono::seconds(30)) {
      last_print = now;
      // Per cell: its progress and ETA from its own rate since it started here; the study's
      // ETA: the env steps left over every unfinished cell at the running cells' summed rate.
      double rate_sum = 0.0;
      std::string line;
      for (const auto& r : running) {
        const auto& c = cells[r.cell];
        const std::int64_t steps = last_env_steps(c.run_dir);
        const double el = std::chrono::duration<double>(now - r.start).count();
        const double rate = el > 0 && steps > r.steps_at_start ? (steps - r.steps_at_start) / el : 0.0;
        rate_sum += rate;
        const double frac = static_cast<double>(steps) / static_cast<double>(cfg.total_env_steps);
        line += " | " + cell_label(c) + " " + std::to_string(static_cast<int>(100 * frac)) + "% ETA " +
                (rate > 0 ? hms((cfg.total_env_steps - steps) / rate) : std::string("?"));
      }
      double left = 0.0;
      for (std::size_t q = next; q < todo.size(); ++q) left += static_cast<double>(cfg.total_env_steps - status[todo[q]].env_steps);
      for (const auto& r : running)
        left += static_cast<double>(cfg.total_env_steps) - static_cast<double>(last_env_steps(cells[r.cell].run_dir));
      std::printf("study: %zu/%zu cells done%s | study ETA %s (trainings)\n", finished, cells.size(), line.c_str(),
                  rate_sum > 0 ? hms(left / rate_sum).c_str() : "?");
      std::fflush(stdout);
    }
    std::this_thread::sleep_for(std::chrono::milliseconds(200));
  }
  if (!failure.empty()) throw io::InputError(failure);
  return !g_stop;
}

// Races one interval's tournament as a child `f16race tournament` (logged like the trainings),
// which writes its folder whole. Returns false when the study was stopped by a signal.
bool race_interval(const eval::TournamentOptions& t, const std::string& out, double dt) {
  const std::string name = eval::interval_name(dt);
  const std::string log = (fs::path(out) / "logs" / (name + "_tournament.log")).string();
  std::vector<std::string> args{"--threads", std::to_string(omp_get_max_threads())};
  for (const std::string& a : eval::tournament_args(t)) args.push_back(a);
  const pid_t pid = spawn_f16race(args, log);
  int ws = 0;
  bool signalled = false;
  while (waitpid(pid, &ws, WNOHANG) != pid) {
    if (g_stop && !signalled) {
      signalled = true;
      kill(pid, SIGINT);
    }
    std::this_thread::sleep_for(std::chrono::milliseconds(200));
  }
  if (g_stop) return false;
  const int code = io::exit_code(ws);
  if (code != 0)
    throw io::InputError(name + " tournament: exited with status " + std::to_string(code) + "; see " + log +
                         ", fix it and run the study again (trained runs are kept)");
  std::string why;
  if (!eval::tournament_complete(t, &why))
    throw io::InputError(name + " tournament: not complete in " + t.out_dir + " (" + why + "); see " + log +
                         ", fix it and run the study again, which races it again");
  return true;
}

// The study folder and its interval folders: created, and cleared of the temporaries of killed
// processes (a staging folder of a tournament or report, a study.yaml.tmp.PID).
void own_study_folder(const eval::StudyConfig& cfg, const std::string& out) {
  fs::create_directories(out);
  std::vector<std::string> removed = io::remove_stale_temporaries(out);
  for (double dt : cfg.dt_hl_s) {
    const std::string dir = eval::interval_dir(out, dt);
    fs::create_directories(dir);
    for (const std::string& r : io::remove_stale_temporaries(dir)) removed.push_back(r);
  }
  if (!removed.empty())
    std::printf("study: removed %zu temporaries left by stopped processes in %s\n", removed.size(), out.c_str());
}

void run_study(const StudyOptions& o) {
  const eval::StudyConfig cfg = eval::read_study_config(o.config);
  const std::vector<eval::StudyCell> cells = eval::plan_study(cfg, o.out);
  if (o.plan_only) {
    for (const auto& c : cells) {
      const eval::CellStatus s = eval::cell_status(cfg, c);
      std::printf("%-24s %-10s %lld / %lld env steps  %s\n", cell_label(c).c_str(), state_name(s.state),
                  static_cast<long long>(s.env_steps), static_cast<long long>(s.total_env_steps), c.run_dir.c_str());
    }
    return;
  }
  // An interval's tournament is done only with its figures: found now, not after hours of training.
  if (!io::gnuplot_available())
    throw io::InputError("study: gnuplot not found; the study's figures need it: install gnuplot-nox, then run it again");
  std::signal(SIGINT, on_signal);
  std::signal(SIGTERM, on_signal);
  own_study_folder(cfg, o.out);
  {  // the study config as run, next to its results
    std::ifstream in(o.config);
    io::write_file_atomic((fs::path(o.out) / "study.yaml").string(),
                          std::string((std::istreambuf_iterator<char>(in)), {}));
  }
  // One interval at a time: its runs, then its tournament and the report so far, so a study
  // cut short (a session's end) has its first horizon finished instead of every run half done.
  double tournament_s = 0.0;
  const std::string report = (fs::path(o.out) / "report" / "report.md").string();
  for (double dt : cfg.dt_hl_s) {
    std::vector<eval::StudyCell> interval_cells;
    for (const auto& c : cells)
      if (eval::interval_name(c.dt_hl_s) == eval::interval_name(dt)) interval_cells.push_back(c);
    std::printf("study: %s\n", eval::interval_name(dt).c_str());
    if (!train_cells(cfg, interval_cells, o.out)) {
      std::printf("study: stopped; every run kept its checkpoint. Run the same command again to continue.\n");
      throw ExitStatus{130};
    }
    const eval::TournamentOptions t = eval::interval_tournament(cfg, cells, dt, o.out);
    if (eval::tournament_complete(t)) {
      std::printf("study: %s tournament already written (delete %s to race it again)\n", eval::interval_name(dt).c_str(),
                  t.out_dir.c_str());
      continue;
    }
    std::printf("study: %s tournament, %zu runs%s, %d races per pair (%s/logs/%s_tournament.log)\n",
                eval::interval_name(dt).c_str(), t.runs.size(), cfg.controls ? " with controls" : "",
                cfg.races_per_pair, o.out.c_str(), eval::interval_name(dt).c_str());
    std::fflush(stdout);
    const auto t0 = Clock::now();
    if (!race_interval(t, o.out, dt)) {
      std::printf("study: stopped during the %s tournament; run the same command again to race it.\n",
                  eval::interval_name(dt).c_str());
      throw ExitStatus{130};
    }
    tournament_s += std::chrono::duration<double>(Clock::now() - t0).count();
    eval::write_study_report(cfg, cells, o.out, o.config, tournament_s);
    std::printf("study: %s done; report so far in %s\n", eval::interval_name(dt).c_str(), report.c_str());
  }
  eval::write_study_report(cfg, cells, o.out, o.config, tournament_s);
  std::printf("study: done; report in %s\n", report.c_str());
}

}  // namespace

void add_study_command(CLI::App& app) {
  auto o = std::make_shared<StudyOptions>();
  CLI::App* cmd = app.add_subcommand(
      "study", "Fig. 3 study: train every variant x seed x HL interval (resumable), tournaments, one report");
  cmd->add_option("--config", o->config, "Study config (default configs/study.yaml)");
  cmd->add_option("--out", o->out, "Study folder (default runs/study); run again to continue an interrupted study");
  cmd->add_flag("--plan", o->plan_only, "List the cells and their state, then exit");
  cmd->callback([o]() { run_study(*o); });
}

}  // namespace f16race::app
