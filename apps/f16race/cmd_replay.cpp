// `f16race replay`: race a trained run once and write what happened: trajectories (CSV), a
// Fig. 4/5-style figure with the HL goals, and a Tacview .acmi file.
#include <CLI/CLI.hpp>
#include <cstdio>
#include <memory>
#include <string>

#include "commands.hpp"
#include "eval/replay.hpp"
#include "io/staged_folder.hpp"

namespace f16race::app {
namespace {

struct ReplayCliOptions {
  eval::ReplayOptions replay;
  std::string out = "runs/replay";
};

void run_replay_command(const ReplayCliOptions& o) {
  // Written into a staging folder beside --out and swapped in whole; a folder that cannot be
  // written fails before the race.
  io::StagedFolder folder(o.out, "replay", eval::is_replay_output);
  const eval::RaceReplay r = eval::run_replay(o.replay);
  std::string msg;
  bool drawn = false;
  folder.commit([&](const std::string& staging) { drawn = eval::write_replay(r, staging, &msg); });
  const auto& t = r.trace;
  std::printf("%s (blue) vs %s (red), seed %llu: %s after %.1f s, winner %s\n", r.blue.c_str(), r.red.c_str(),
              static_cast<unsigned long long>(o.replay.seed), race::end_reason_name(t.end), t.duration_s,
              t.winner < 0 ? "draw" : (t.winner == 0 ? "blue" : "red"));
  for (std::size_t a = 0; a < t.rows.size(); ++a)
    if (t.cause[a] != race::kCauseNone)
      std::printf("  aircraft %zu out at %.1f s: %s\n", a, t.out_s[a], race::cause_name(t.cause[a]));
  std::printf("written: %s/{replay.md, replay_agent*.csv, replay_goals.csv, replay.acmi%s}\n", o.out.c_str(),
              drawn ? ", replay.png" : "");
  if (!drawn) std::printf("figure not drawn: %s\n", msg.c_str());
}

}  // namespace

void add_replay_command(CLI::App& app) {
  auto o = std::make_shared<ReplayCliOptions>();
  CLI::App* cmd = app.add_subcommand("replay", "Race a trained run once; write trajectories, a figure and a Tacview file");
  cmd->add_option("--run", o->replay.run,
                  "Run folder (blue team); RUN@center or RUN@random flies its low level under a fixed high level, "
                  "RUN@center_x/_y/_z its high level with that goal axis on the middle bin")
      ->required();
  cmd->add_option("--opponent", o->replay.opponent,
                  "Red team: a run folder (@center, @random, @center_x/_y/_z allowed), self (default), untrained, scripted or autopilot (AeroBench's waypoint autopilot)");
  cmd->add_option("--seed", o->replay.seed, "Seed of the track and the start")->check(kNonNegativeSeed);
  cmd->add_option("--epsilon", o->replay.epsilon, "HL exploration (default 0: greedy)")->check(CLI::Range(0.0, 1.0));
  cmd->add_option("--out", o->out,
                  "Output folder, replaced whole by the new replay (a folder holding other files than a replay's "
                  "is refused)");
  cmd->callback([o]() { run_replay_command(*o); });
}

}  // namespace f16race::app
