// `f16race replay`: race a trained run once and write what happened: trajectories (CSV), a
// Fig. 4/5-style figure with the HL goals, a Tacview .acmi file and, with --html, the 3-D page.
#include <CLI/CLI.hpp>
#include <algorithm>
#include <cstdio>
#include <filesystem>
#include <memory>
#include <string>

#include "commands.hpp"
#include "race_settings.hpp"
#include "eval/replay.hpp"
#include "eval/replay_page.hpp"
#include "io/input_error.hpp"
#include "io/staged_folder.hpp"

namespace f16race::app {
namespace {

namespace fs = std::filesystem;

struct ReplayCliOptions {
  eval::ReplayOptions replay;
  std::vector<std::string> sets;  // --set race.KEY=VALUE
  std::string out = "runs/replay";
  std::string html;  // empty: no page
};

// Where --html goes: "" to write it at o.html after the folder, or its name inside --out, which
// is swapped in whole, so the page is staged with the rest. Refuses, before the race, a path that
// is a folder or under a file, or that lies in --out under a name the next replay would not own.
std::string html_in_out_folder(const ReplayCliOptions& o) {
  if (o.html.empty()) return "";
  std::error_code ec;
  if (fs::is_directory(o.html, ec)) throw io::InputError("--html " + o.html + ": is a folder; name the page's file, e.g. race.html");
  const fs::path parent = fs::absolute(o.html).parent_path();
  if (fs::exists(parent, ec) && !fs::is_directory(parent, ec))
    throw io::InputError("--html " + o.html + ": " + parent.string() + " is not a folder");
  const fs::path page = fs::weakly_canonical(fs::absolute(o.html));
  fs::path out = fs::weakly_canonical(fs::absolute(o.out));
  if (out.filename().empty()) out = out.parent_path();  // "runs/replay/"
  if (std::mismatch(out.begin(), out.end(), page.begin(), page.end()).first != out.end()) return "";  // not inside --out
  const std::string name = page.filename().string();
  if (page.parent_path() != out || !eval::is_replay_output(name))
    throw io::InputError("--html " + o.html + ": inside --out " + o.out + ", which replay replaces whole; name it " +
                         o.out + "/replay.html or put it outside that folder");
  return name;
}

void run_replay_command(ReplayCliOptions o) {
  apply_race_settings(o.sets, {{"goal_shift_up_frac", -0.8, 0.8, &o.replay.goal_shift_up_frac}}, "replay");
  // Written into a staging folder beside --out and swapped in whole; a folder that cannot be
  // written fails before the race.
  const std::string html_inside = html_in_out_folder(o);
  io::StagedFolder folder(o.out, "replay", eval::is_replay_output);
  const eval::RaceReplay r = eval::run_replay(o.replay);
  std::string msg;
  bool drawn = false;
  folder.commit([&](const std::string& staging) {
    drawn = eval::write_replay(r, staging, &msg);
    if (!html_inside.empty()) eval::write_replay_page(r, staging + "/" + html_inside);
  });
  if (!o.html.empty() && html_inside.empty()) eval::write_replay_page(r, o.html);
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
  if (!o.html.empty()) std::printf("3-D page: %s (open it in a browser; docs/viewer.md)\n", o.html.c_str());
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
                  "Red team: a run folder (@center, @random, @center_x/_y/_z allowed), self (default), untrained, scripted, autopilot (AeroBench's waypoint autopilot) or autopilot@line (the autopilot on the race's racing line)");
  cmd->add_option("--seed", o->replay.seed, "Seed of the track and the start")->check(kNonNegativeSeed);
  cmd->add_option("--epsilon", o->replay.epsilon, "HL exploration (default 0: greedy)")->check(CLI::Range(0.0, 1.0));
  cmd->add_option("--set", o->sets,
                  "A race setting for both teams instead of the run's: race.goal_shift_up_frac=X moves every goal up by "
                  "X of the tube radius (negative: down)");
  cmd->add_option("--out", o->out,
                  "Output folder, replaced whole by the new replay (a folder holding other files than a replay's "
                  "is refused)");
  cmd->add_option("--html", o->html,
                  "Also write the race as one self-contained 3-D page (three.js inlined, opens from disk with no "
                  "network; race.html#t=20 opens at 20 s): docs/viewer.md")
      ->check(CLI::Validator([](std::string& v) { return v.empty() ? std::string("needs a file name, e.g. race.html") : std::string(); },
                             "FILE"));
  cmd->callback([o]() { run_replay_command(*o); });
}

}  // namespace f16race::app
