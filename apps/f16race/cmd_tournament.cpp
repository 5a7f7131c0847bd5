// `f16race tournament`: round-robin between trained runs (and the untrained networks, and
// optionally fixed-HL controls), with per-variant mean +- std, IQM with a stratified-bootstrap
// CI, a pairing table and figures.
#include <omp.h>
#include <torch/torch.h>
#include <unistd.h>

#include <CLI/CLI.hpp>
#include <chrono>
#include <cstdio>
#include <filesystem>
#include <memory>
#include <sstream>
#include <string>
#include <vector>

#include "commands.hpp"
#include "dist_options.hpp"
#include "progress_bar.hpp"
#include "race_settings.hpp"
#include "eval/tournament.hpp"
#include "eval/tournament_journal.hpp"
#include "eval/tournament_output.hpp"
#include "eval/tournament_report.hpp"
#include "io/staged_folder.hpp"

namespace f16race::app {
namespace {

// What every rank of a distributed tournament must agree on: the binary and every option.
std::string fingerprint(const eval::TournamentOptions& o) {
  std::ostringstream f;
  f << "binary " << std::hex << dist::executable_hash() << std::dec << "\ntournament";
  for (const std::string& r : o.runs) f << "\n--runs " << r;
  f << "\n--races " << o.races_per_pair << "\n--seed " << o.seed << "\n--epsilon " << o.epsilon << "\n--batch "
    << o.batch_envs << "\n--bootstrap " << o.bootstrap_replicates << "\nuntrained " << o.include_untrained << " "
    << o.untrained_in_statistics << "\n--with-autopilot " << o.include_autopilot << "\n--controls " << o.controls
    << "\n--axis-controls " << o.axis_controls << "\n--controls-own-run " << o.controls_own_run
    << "\nrace.autopilot_airspeed_ftps " << o.autopilot_airspeed_ftps
    << "\n--tracks " << o.tracks_config << "\nrace.goal_line_frac " << o.goal_line_frac << "\nrace.goal_shift_up_frac "
    << o.goal_shift_up_frac << "\n--autopilot-on-line " << o.autopilot_on_line << "\nrace.autopilot_shift_up_frac "
    << o.autopilot_shift_up_frac
    << "\n--out " << o.out_dir;
  return f.str();
}

void run(const eval::TournamentOptions& o, const dist::DistConfig& dc) {
  torch::set_num_threads(omp_get_max_threads());
  // A group of ranks shares the races; rank 0 alone prints and writes the report.
  std::unique_ptr<dist::Group> group;
  if (dc.world_size > 1) group = std::make_unique<dist::Group>(dc, fingerprint(o));
  if (group && group->rank() != 0) {
    eval::run_tournament(o, {}, group.get());
    return;
  }
  const bool tty = isatty(STDOUT_FILENO) != 0;
  eval::TournamentResult r;
  const auto start = std::chrono::steady_clock::now();
  int last_percent = -1;
  // The output folder first: one that cannot be made, or holds other files, fails now, not after
  // every race. The report is written into a staging folder beside it and swapped in whole.
  io::StagedFolder out(o.out_dir, "tournament", eval::is_tournament_output);
  // A missing folder is made now, empty until the output is swapped in: that a tournament has
  // started shows (the group tests wait for it), and a kill leaves it empty, never partial.
  std::error_code ec;
  const bool made_here = !std::filesystem::exists(o.out_dir, ec);
  std::filesystem::create_directories(o.out_dir, ec);
  if (ec) throw io::InputError(o.out_dir + ": cannot create the output folder (" + ec.message() + "); choose another --out");
  // The races so far go to a journal beside the folder, so a stopped tournament goes on where it
  // stopped; it is removed once the output is in place.
  eval::TournamentOptions journaled = o;
  journaled.journal_path = eval::tournament_journal_path(o.out_dir);
  const auto progress = [&](long done, long total) {
    const double frac = total > 0 ? static_cast<double>(done) / static_cast<double>(total) : 1.0;
    const double elapsed = std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count();
    const double left = frac > 0.0 ? elapsed * (1.0 - frac) / frac : 0.0;
    const int percent = static_cast<int>(100.0 * frac);
    if (tty) {
      char text[160];
      std::snprintf(text, sizeof text, "%3d%%  %ld / %ld races  %.0f s elapsed, ~%.0f s left", percent, done, total,
                    elapsed, left);
      print_progress_bar(frac, 40, text);
    } else if (percent / 10 != last_percent / 10 || done == total) {  // a log line every 10 %
      std::printf("%3d%%  %ld / %ld races  %.0f s elapsed\n", percent, done, total, elapsed);
    }
    last_percent = percent;
    std::fflush(stdout);
  };
  try {
    r = eval::run_tournament(journaled, progress, group.get(), [](const std::string& line) { std::printf("%s\n", line.c_str()); });
  } catch (...) {
    // Refused (its runs or options) or failed: a folder made above goes again if still empty; the
    // journal beside it stays, so the races already run are not lost.
    if (made_here) std::filesystem::remove(o.out_dir, ec);
    throw;
  }
  if (tty) std::printf("\n");
  std::string md;
  std::vector<std::string> missing;
  out.commit([&](const std::string& staging) {
    eval::TournamentOptions staged = o;
    staged.out_dir = staging;
    md = eval::write_tournament_report(r, staged, &missing);
  });
  std::filesystem::remove(journaled.journal_path, ec);  // a journal left by a kill here is whole: reused, not raced
  std::printf("%s", md.c_str());
  std::printf("%zu races in %.1f s\n", r.races.size(),
              std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count());
  std::printf("written: %s/{races.csv, pairings.csv, summary.md, summary.json%s, done.txt}\n", o.out_dir.c_str(),
              missing.empty() ? ", tournament.png, pairings.png" : "");
  if (!missing.empty()) {
    std::string line;
    for (const std::string& m : missing) line += (line.empty() ? "" : "; ") + m;
    std::printf("figures not drawn (data and gnuplot scripts are written; listed in %s/done.txt): %s\n",
                 o.out_dir.c_str(), line.c_str());
  }
}

}  // namespace

void add_tournament_command(CLI::App& app) {
  auto o = std::make_shared<eval::TournamentOptions>();
  o->out_dir = "runs/tournament";
  CLI::App* cmd = app.add_subcommand("tournament", "Round-robin evaluation of trained runs with honest statistics");
  cmd->add_option("--runs", o->runs, "Run folders (written by f16race train)")->required();
  cmd->add_option("--races", o->races_per_pair, "Races per pair of entries (sides swapped in half)")
      ->check(CLI::Range(2, 1000000));
  cmd->add_option("--seed", o->seed, "Seed of the tracks and starts (and of the @random controls)")
      ->check(kNonNegativeSeed);
  cmd->add_option("--epsilon", o->epsilon, "HL exploration while evaluating (default 0: greedy)")->check(CLI::Range(0.0, 1.0));
  cmd->add_option("--batch", o->batch_envs, "Races run at once")->check(CLI::Range(1, 100000));
  cmd->add_option("--bootstrap", o->bootstrap_replicates, "Bootstrap replicates for the IQM CI")->check(CLI::Range(100, 1000000));
  CLI::Option* no_untrained =
      cmd->add_flag("!--no-untrained", o->include_untrained, "Leave out the built-in untrained entry");
  cmd->add_flag("--with-untrained", o->untrained_in_statistics,
                "Count the untrained entry in the per-variant statistics (by default it is only listed)")
      ->excludes(no_untrained);
  cmd->add_flag("--with-autopilot", o->include_autopilot,
                "Add the entry 'autopilot': AeroBench's waypoint autopilot flying each aircraft's start lane along "
                "the track, a non-learned reference; listed, never in the variant statistics");
  cmd->add_flag("--controls", o->controls,
                "Add RUN@center and RUN@random for every run: its low level under a fixed high level (middle bin, "
                "or uniform random bins); listed, never in the variant statistics");
  cmd->add_flag("--axis-controls", o->axis_controls,
                "Add RUN@center_x, RUN@center_y and RUN@center_z for every run: its trained high level with one goal "
                "axis (track frame: along, right, up) held on the middle bin; listed, never in the variant statistics");
  cmd->add_flag("--controls-own-run", o->controls_own_run,
                "Each control entry races its own run alone, not the other entries and controls: what the high "
                "level adds, in a fraction of the races");
  cmd->add_flag("--autopilot-on-line", o->autopilot_on_line,
                "The autopilot entry flies its start lanes shifted onto each race's racing line (the race's "
                "race.goal_line_frac), its aim points held within 0.8 of the radius");
  cmd->add_option("--tracks", o->tracks_config,
                  "Race on this config's tracks and time limit (race.track, race.time_limit_s), e.g. configs/long.yaml; "
                  "default: the first run's")
      ->check(CLI::ExistingFile);
  auto sets = std::make_shared<std::vector<std::string>>();
  cmd->add_option("--set", *sets,
                  "A race setting for every entry instead of the first run's (repeatable): race.goal_line_frac "
                  "(goals around the racing line within that fraction of the radius; 0: the center-line), "
                  "race.goal_shift_up_frac (every goal moved up by that fraction; negative: down), "
                  "race.autopilot_shift_up_frac and race.autopilot_airspeed_ftps (the autopilot entry's height and "
                  "set point)");
  cmd->add_option("--out", o->out_dir,
                  "Output folder, replaced whole when the tournament is written (a folder holding other files than "
                  "a tournament's is refused)");
  auto dist_flags = std::make_shared<DistFlags>();
  dist_flags->add_to(cmd);
  cmd->callback([o, sets, dist_flags]() {
    apply_race_settings(*sets,
                        {{"goal_line_frac", 0.0, 0.95, &o->goal_line_frac},
                         {"goal_shift_up_frac", -0.8, 0.8, &o->goal_shift_up_frac},
                         {"autopilot_shift_up_frac", -0.8, 0.8, &o->autopilot_shift_up_frac},
                         {"autopilot_airspeed_ftps", 300.0, 3000.0, &o->autopilot_airspeed_ftps}},
                        "tournament");
    run(*o, dist_flags->resolve());
  });
}

}  // namespace f16race::app
