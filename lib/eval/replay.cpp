#include "eval/replay.hpp"

#include <torch/torch.h>

#include <cmath>
#include <cstdio>
#include <filesystem>
#include <fstream>
#include <optional>
#include <sstream>
#include <stdexcept>
#include <vector>

#include "eval/tournament.hpp"
#include "io/atomic_file.hpp"
#include "io/input_error.hpp"
#include "race/race_env.hpp"
#include "race/scripted_pilot.hpp"
#include "train/obs_views.hpp"
#include "train/policy_rows.hpp"
#include "train/run_policy.hpp"

namespace f16race::eval {

namespace fs = std::filesystem;

namespace {

// One team's pilots: a learned policy (with its own HL, or a fixed HL rule as the tournament's
// RUN@center / RUN@random controls), or a built-in pilot without networks (policy empty): the
// scripted pilot or AeroBench's waypoint autopilot.
struct Side {
  std::string name;
  std::optional<train::RunPolicy> policy;
  HlOverride hl = HlOverride::none;
};

// The autopilot on the race's racing line, as `tournament --autopilot-on-line` flies it.
constexpr const char* kAutopilotOnLine = "autopilot@line";

std::string with_rule(const std::string& name, HlOverride rule) {
  return rule == HlOverride::none ? name : name + "@" + hl_override_name(rule);
}

Side make_side(const std::string& spec, const train::RunPolicy* blue, std::uint64_t seed) {
  if (spec == kAutopilotOnLine) return Side{spec, std::nullopt};  // not a RUN@rule
  const auto [path, rule] = parse_entry_spec(spec);
  if (path == "scripted" || path == "autopilot") {
    if (rule != HlOverride::none) throw io::InputError(spec + ": the " + path + " pilot has no high level to fix");
    return Side{path, std::nullopt};
  }
  if (path == "untrained") return Side{with_rule("untrained", rule), train::untrained_policy(blue->config, seed), rule};
  train::RunPolicy p = train::load_policy_spec(path);
  train::check_same_race_shape(*blue, p);
  const std::string name = with_rule(p.name, rule);
  return Side{name, std::move(p), rule};
}

// The built-in autopilot as the tournament races it: the tuned baseline (docs/race.md), or
// on the race's racing line for `autopilot@line`, which a center-line run's race does not have.
race::AutopilotPilotConfig replay_autopilot(const race::RaceConfig& rc, const race::RaceEnv& env,
                                            const std::string& red_name, const std::string& run) {
  race::AutopilotPilotConfig autopilot;
  autopilot.airspeed_ftps = rc.autopilot_airspeed();
  autopilot.shift_up_frac = rc.autopilot_shift_up_frac;
  if (red_name == kAutopilotOnLine) {
    if (!env.racing_line(0))
      throw io::InputError(run + ": trained on the center-line (race.goal_line_frac 0): " + kAutopilotOnLine +
                           " flies the race's racing line, and this race has none; use --opponent autopilot");
    autopilot.lines = &env.racing_lines();
  }
  return autopilot;
}

// Each side's networks act on its own team's rows only: policy 0 is blue's, 1 red's; the
// scripted pilot flies no network, a fixed-HL control none at the high level.
void assign_side_rows(const Side& blue, const Side& red, int n_agent, int team_size,
                      train::PolicyRows* ll_rows, train::PolicyRows* hl_rows) {
  std::vector<int> ll_owner(n_agent, -1), hl_owner(n_agent, -1);
  for (int a = 0; a < n_agent; ++a) {
    const int team = a < team_size ? 0 : 1;
    const Side& s = team == 0 ? blue : red;
    ll_owner[a] = s.policy ? team : -1;
    hl_owner[a] = s.policy && hl_override_uses_policy(s.hl) ? team : -1;
  }
  ll_rows->assign(ll_owner);
  hl_rows->assign(hl_owner);
}

std::string seconds(double t) {
  char b[32];
  std::snprintf(b, sizeof b, "%.2f", t);
  return b;
}

}  // namespace

RaceReplay run_replay(const ReplayOptions& o) {
  torch::NoGradGuard no_grad;
  const auto [blue_path, blue_rule] = parse_entry_spec(o.run);
  Side blue{"", train::load_policy_spec(blue_path), blue_rule};
  blue.name = with_rule(blue.policy->name, blue_rule);
  const std::string opp = o.opponent.empty() || o.opponent == "self" ? o.run : o.opponent;
  Side red = make_side(opp, &*blue.policy, o.seed);

  race::RaceConfig rc = blue.policy->config.race;
  rc.n_env = 1;
  rc.seed = o.seed;
  if (!std::isnan(o.goal_shift_up_frac)) rc.goal_shift_up_frac = o.goal_shift_up_frac;
  race::RaceEnv env(rc);
  race::RaceRecorder rec(env);
  // Taken now: when the race ends the env starts another on a new track.
  const race::TubeLine line = env.racing_line(0) ? *env.racing_line(0) : race::TubeLine{};
  const int n_agent = env.n_agent(), ts = rc.team_size;
  std::vector<std::int64_t> bins(static_cast<std::size_t>(n_agent) * race::kHlDims, rc.hl_center_bin());
  std::vector<float> actions(static_cast<std::size_t>(n_agent) * race::kActionDim, 0.0f);
  race::ScriptedPilotConfig pilot;
  pilot.speed_ftps = rc.start_speed_ftps;
  const race::AutopilotPilotConfig autopilot = replay_autopilot(rc, env, red.name, o.run);
  at::Generator gen = models::make_generator(o.seed * 31 + 7);
  RandomStream control_rng = control_stream(o.seed, 0);  // the @random rule's draws
  std::vector<std::uint8_t> learned(n_agent);  // agents whose HL goals mean something
  for (int a = 0; a < n_agent; ++a) learned[a] = (a < ts ? blue : red).policy.has_value();
  train::PolicyRows ll_rows(2, n_agent), hl_rows(2, n_agent);
  assign_side_rows(blue, red, n_agent, ts, &ll_rows, &hl_rows);
  std::vector<std::int64_t> red_rows(static_cast<std::size_t>(ts));
  for (int k = 0; k < ts; ++k) red_rows[static_cast<std::size_t>(k)] = ts + k;
  race::BlockCounter block_counter(env);
  while (rec.remaining() > 0) {
    const std::vector<std::uint8_t> due(env.hl_due(), env.hl_due() + 1);
    if (due[0]) {
      const models::HlObs obs = train::hl_obs_view(env);
      for (int team = 0; team < 2; ++team) {
        const Side& s = team == 0 ? blue : red;
        if (!s.policy) continue;  // the scripted pilot keeps the center-line goal
        if (hl_override_uses_policy(s.hl))
          train::policy_hl_bins(*s.policy, obs, hl_rows.rows(team), o.epsilon, gen, bins.data());
        if (s.hl != HlOverride::none)  // after the policy: a one-axis rule fixes that axis of its bins
          fixed_hl_bins(s.hl, rc.hl_bins, ts, control_rng,
                        bins.data() + static_cast<std::size_t>(team * ts) * race::kHlDims);
      }
      env.set_hl_actions(bins.data());
      rec.record_goals(env, due.data(), learned.data());
    }
    // A built-in pilot flies the red team's rows only (the blue side is always a run).
    if (!red.policy) {
      if (red.name != "scripted") race::autopilot_actions(env, autopilot, actions.data(), red_rows.data(), ts);
      else race::scripted_actions(env, pilot, actions.data(), red_rows.data(), ts);
    }
    const models::LlObs obs = train::ll_obs_view(env);
    for (int team = 0; team < 2; ++team) {
      const Side& s = team == 0 ? blue : red;
      if (s.policy) train::greedy_ll_actions(*s.policy, env, obs, ll_rows.rows(team), gen, actions.data());
    }
    rec.before_step(env);
    env.step(actions.data());
    rec.after_step(env);
    block_counter.after_step(race::block_view(env));
  }
  return RaceReplay{rec.trace(0), blue.name, red.name, block_counter.events(), rc, line};
}

bool write_replay(const RaceReplay& r, const std::string& out_dir, std::string* message) {
  fs::create_directories(out_dir);
  const race::RaceTrace& t = r.trace;
  race::write_trace_csv(t, out_dir, "replay");
  const std::string blue = "Blue: " + r.blue, red = "Red: " + r.red;
  const std::string winner = t.winner < 0 ? "draw" : (t.winner == 0 ? blue : red);
  const std::string title = blue + " vs " + red + " - " + race::end_reason_name(t.end) + ", winner " + winner;
  race::write_trace_acmi(t, out_dir + "/replay.acmi", title, {blue, red});
  std::ostringstream md;
  md << "# Replay: " << r.blue << " (blue) vs " << r.red << " (red)\n\n"
     << "Ended by " << race::end_reason_name(t.end) << " after " << t.duration_s << " s; winner: " << winner
     << ". Track " << static_cast<long>(t.track.length_ft()) << " ft.\n\n| aircraft | team | fate | HL decisions |\n|---|---|---|---|\n";
  for (std::size_t a = 0; a < t.rows.size(); ++a) {
    const int team = race::RaceEnv::team_of(static_cast<int>(a), t.team_size);
    md << "| " << a << " | " << (team == 0 ? "blue" : "red") << " | "
       << (t.cause[a] == race::kCauseNone ? std::string("in the race at the end")
                                          : "out at " + seconds(t.out_s[a]) + " s (" + race::cause_name(t.cause[a]) + ")")
       << " | " << t.goals[a].size() << " |\n";
  }
  md << "\nBlocks (an aircraft <= 1000 ft ahead of an opponent and <= 300 ft from it in the tube's cross-section; "
        "within 5 s the opponent was taken out, or passed by the blocker's teammate while still behind the blocker; docs/race.md, \"Blocks\"): ";
  if (r.blocks.empty()) {
    md << "none.\n";
  } else {
    md << r.blocks.size() << ".\n\n| blocker | blocked | in front from | outcome at | outcome |\n|---|---|---|---|---|\n";
    for (const race::BlockEvent& b : r.blocks) {
      const auto who = [&](int a) {
        return std::to_string(a) + (race::RaceEnv::team_of(a, t.team_size) == 0 ? " (blue)" : " (red)");
      };
      md << "| " << who(b.blocker) << " | " << who(b.blocked) << " | " << seconds(b.t_open_s) << " s | "
         << seconds(b.t_s) << " s | " << (b.taken_out ? "taken out" : "passed by a teammate") << " |\n";
    }
  }
  io::write_file_atomic(out_dir + "/replay.md", md.str());
  race::write_blocks_csv(t, r.blocks, out_dir, "replay");
  return race::plot_trace(t, out_dir, "replay", title, message, r.blocks);
}

bool is_replay_output(const std::string& name) { return name.rfind("replay.", 0) == 0 || name.rfind("replay_", 0) == 0; }

}  // namespace f16race::eval
