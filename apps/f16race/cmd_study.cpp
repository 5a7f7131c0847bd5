// `f16race study`: the Fig. 3 study in pieces (eval::run_study schedules it). Interrupt it at any
// time (Ctrl-C or SIGTERM is forwarded to the children: a training checkpoints and stops, a
// tournament stops; the study waits for them and exits 130) and run the same command again to
// continue.
#include <CLI/CLI.hpp>
#include <atomic>
#include <csignal>
#include <cstdio>
#include <memory>
#include <string>
#include <vector>

#include "commands.hpp"
#include "eval/study.hpp"
#include "eval/study_runner.hpp"

namespace f16race::app {
namespace {

struct StudyOptions {
  std::string config = "configs/study.yaml";
  std::string out = "runs/study";
  bool plan_only = false;
};

std::atomic<bool> g_study_stop{false};
void on_signal(int) { g_study_stop = true; }

void print_plan(const eval::StudyConfig& cfg, const std::vector<eval::StudyCell>& cells) {
  for (const auto& c : cells) {
    const eval::CellStatus s = eval::cell_status(cfg, c);
    std::printf("%-24s %-10s %lld / %lld env steps  %s\n", eval::cell_label(c).c_str(), eval::cell_state_name(s.state),
                static_cast<long long>(s.env_steps), static_cast<long long>(s.total_env_steps), c.run_dir.c_str());
  }
}

void run_study(const StudyOptions& o) {
  eval::StudyRun run;
  run.config = eval::read_study_config(o.config);
  run.cells = eval::plan_study(run.config, o.out);
  if (o.plan_only) return print_plan(run.config, run.cells);
  run.config_path = o.config;
  run.out = o.out;
  run.stop = &g_study_stop;
  run.say = [](const std::string& line) {
    std::fputs(line.c_str(), stdout);
    std::fflush(stdout);
  };
  std::signal(SIGINT, on_signal);
  std::signal(SIGTERM, on_signal);
  if (!eval::run_study(run)) throw ExitStatus{130};
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
