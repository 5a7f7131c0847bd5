#include "eval/tournament.hpp"

#include <torch/torch.h>
#include <yaml-cpp/yaml.h>

#include <algorithm>
#include <numeric>
#include <cmath>
#include <filesystem>
#include <fstream>
#include <map>
#include <memory>
#include <set>
#include <sstream>
#include <stdexcept>

#include "dist/process_group.hpp"
#include "eval/tournament_journal.hpp"
#include "eval/tournament_output.hpp"
#include "io/atomic_file.hpp"
#include "io/input_error.hpp"
#include "race/block_events.hpp"
#include "io/yaml_config.hpp"
#include "race/race_env.hpp"
#include "race/scripted_pilot.hpp"
#include "train/obs_views.hpp"
#include "train/policy_rows.hpp"
#include "train/run_policy.hpp"
#include "train/train_config.hpp"

namespace f16race::eval {

namespace fs = std::filesystem;
using models::HlObs;
using models::LlObs;

namespace {
// Every HL rule in one place: its name (an entry's "@" suffix), how reports describe it, and
// whether the run's own HL policy chooses the bins it does not fix.
struct RuleInfo {
  HlOverride rule;
  const char* name;
  const char* description;
  bool uses_policy;
};
constexpr RuleInfo kRules[] = {
    {HlOverride::none, "policy", "policy", true},
    {HlOverride::center, "center", "fixed: middle bin", false},
    {HlOverride::random, "random", "fixed: uniform random bins", false},
    {HlOverride::center_x, "center_x", "policy, x on the middle bin", true},
    {HlOverride::center_y, "center_y", "policy, y on the middle bin", true},
    {HlOverride::center_z, "center_z", "policy, z on the middle bin", true},
};
const RuleInfo& rule_info(HlOverride rule) {
  for (const RuleInfo& r : kRules)
    if (r.rule == rule) return r;
  return kRules[0];
}
}  // namespace

const char* hl_override_name(HlOverride rule) { return rule_info(rule).name; }
const char* hl_override_description(HlOverride rule) { return rule_info(rule).description; }
bool hl_override_uses_policy(HlOverride rule) { return rule_info(rule).uses_policy; }
const std::vector<HlOverride>& hl_override_rules() {
  static const std::vector<HlOverride> rules = [] {
    std::vector<HlOverride> v;
    for (const RuleInfo& r : kRules)
      if (r.rule != HlOverride::none) v.push_back(r.rule);
    return v;
  }();
  return rules;
}

std::pair<std::string, HlOverride> parse_entry_spec(const std::string& spec) {
  for (HlOverride rule : hl_override_rules()) {
    const std::string suffix = std::string("@") + hl_override_name(rule);
    if (spec.size() > suffix.size() && spec.compare(spec.size() - suffix.size(), suffix.size(), suffix) == 0)
      return {spec.substr(0, spec.size() - suffix.size()), rule};
  }
  // RUN@something else is a typo of a rule, not a folder name (which would fail as "not a run").
  const auto at = spec.rfind('@');
  if (at != std::string::npos && at > 0 && spec.find('/', at) == std::string::npos && !std::filesystem::exists(spec))
    throw io::InputError(spec + ": unknown high-level rule '" + spec.substr(at) +
                             "'; use RUN, RUN@center, RUN@random or RUN@center_x / _y / _z");
  return {spec, HlOverride::none};
}

void fixed_hl_bins(HlOverride rule, int hl_bins, int n_aircraft, RandomStream& rng, std::int64_t* out) {
  const std::size_t n = static_cast<std::size_t>(n_aircraft) * race::kHlDims;
  switch (rule) {
    case HlOverride::center:
      std::fill(out, out + n, static_cast<std::int64_t>(race::center_hl_bin(hl_bins)));
      return;
    case HlOverride::random:
      for (std::size_t k = 0; k < n; ++k) out[k] = rng.below(hl_bins);
      return;
    case HlOverride::center_x:
    case HlOverride::center_y:
    case HlOverride::center_z: {
      const std::size_t axis = rule == HlOverride::center_x ? 0 : rule == HlOverride::center_y ? 1 : 2;
      for (std::size_t k = axis; k < n; k += race::kHlDims) out[k] = race::center_hl_bin(hl_bins);
      return;
    }
    case HlOverride::none:
      break;
  }
  throw std::invalid_argument("fixed_hl_bins: HlOverride::none means the run's own HL policy, not a fixed rule");
}

RandomStream control_stream(std::uint64_t seed, int race) {
  // Not the (seed * 1000003, ...) streams that draw the tracks: its own ids under the plain seed.
  return RandomStream(seed, 0xC0470000ULL + static_cast<std::uint64_t>(race));
}

std::uint64_t track_stream_id(int track) { return 0x7A0C000000000000ULL + static_cast<std::uint64_t>(track); }

bool in_variant_statistics(const Entry& entry, const TournamentOptions& options) {
  if (is_control(entry) || is_autopilot(entry)) return false;
  if (is_untrained(entry)) return options.untrained_in_statistics;
  return true;
}

namespace {

struct Game {
  int pair, blue, red;
  int race;  // index in its pairing: track race / 2, sides swapped on odd races
};

// Every rank's race records, on every rank: fixed-width rows of doubles (each field a small
// integer or the duration, exact in a double), padded to the longest rank's count.
std::vector<RaceRecord> gather_races(dist::Group& group, const std::vector<RaceRecord>& mine, std::uint64_t track_seed) {
  constexpr std::size_t kBase = 11, kFields = kBase + 2 * race::kNumCauses;
  std::vector<std::int64_t> counts(group.size(), 0);
  counts[group.rank()] = static_cast<std::int64_t>(mine.size());
  group.allreduce_sum(counts);
  const std::size_t rows = static_cast<std::size_t>(*std::max_element(counts.begin(), counts.end()));
  std::vector<double> packed(rows * kFields, -1.0);
  for (std::size_t i = 0; i < mine.size(); ++i) {
    const RaceRecord& r = mine[i];
    const double f[kFields] = {double(r.pair),     double(r.blue),      double(r.red),       double(r.env),
                               double(r.race),     double(r.track),     double(r.winner),    double(r.end_reason),
                               r.duration_s,       double(r.blue_blocks), double(r.red_blocks)};
    double* row = packed.data() + i * kFields;
    std::copy(f, f + kBase, row);
    for (int c = 0; c < race::kNumCauses; ++c) {
      row[kBase + c] = r.blue_lost[c];
      row[kBase + race::kNumCauses + c] = r.red_lost[c];
    }
  }
  const std::vector<double> all = group.allgather(packed);
  std::vector<RaceRecord> out;
  for (int q = 0; q < group.size(); ++q)
    for (std::int64_t i = 0; i < counts[q]; ++i) {
      const double* f = all.data() + (static_cast<std::size_t>(q) * rows + static_cast<std::size_t>(i)) * kFields;
      RaceRecord r;
      r.pair = static_cast<int>(f[0]);
      r.blue = static_cast<int>(f[1]);
      r.red = static_cast<int>(f[2]);
      r.env = static_cast<int>(f[3]);
      r.race = static_cast<int>(f[4]);
      r.track = static_cast<int>(f[5]);
      r.winner = static_cast<int>(f[6]);
      r.end_reason = static_cast<int>(f[7]);
      r.duration_s = f[8];
      r.blue_blocks = static_cast<int>(f[9]);
      r.red_blocks = static_cast<int>(f[10]);
      for (int c = 0; c < race::kNumCauses; ++c) {
        r.blue_lost[c] = static_cast<int>(f[kBase + c]);
        r.red_lost[c] = static_cast<int>(f[kBase + race::kNumCauses + c]);
      }
      r.track_seed = track_seed;
      out.push_back(r);
    }
  return out;
}

// What a journal must have been written for: this build, the options that decide the races, the
// tracks file's bytes and each run's checkpoint (a run trained further is another entry).
std::string journal_identity(const TournamentOptions& o, const std::vector<train::RunPolicy>& pol) {
  std::ostringstream s;
  s << "binary " << std::hex << dist::executable_hash() << std::dec << "; " << tournament_marker_options(o)
    << " checkpoints=";
  for (const train::RunPolicy& p : pol)
    s << p.name << ":" << fs::path(p.checkpoint_dir).filename().string() << ":" << p.env_steps << ",";
  return s.str();
}

// The journal of this tournament's races so far; `todo` is left with the games it does not hold.
// Game k of `games` is race k % races_per_pair of pairing k / races_per_pair.
std::unique_ptr<TournamentJournal> open_journal(const TournamentOptions& o, const std::vector<train::RunPolicy>& pol,
                                                const std::vector<Game>& games, std::vector<Game>* todo) {
  const std::size_t per_pair = static_cast<std::size_t>(o.races_per_pair);
  std::vector<char> raced(games.size(), 0);
  auto index = [&](const RaceRecord& r) { return static_cast<std::size_t>(r.pair) * per_pair + r.race; };
  auto accept = [&](const RaceRecord& r) {
    if (r.pair < 0 || r.race < 0 || r.race >= o.races_per_pair || index(r) >= games.size() || raced[index(r)])
      return false;
    const Game& g = games[index(r)];
    if (g.blue != r.blue || g.red != r.red || r.track != r.race / 2 ||
        (r.winner != -1 && r.winner != r.blue && r.winner != r.red))
      return false;
    raced[index(r)] = 1;
    return true;
  };
  auto journal = std::make_unique<TournamentJournal>(o.journal_path, journal_identity(o, pol), accept);
  // A journal refused part way marked some games: count only what it kept.
  std::fill(raced.begin(), raced.end(), 0);
  for (const RaceRecord& r : journal->kept()) raced[index(r)] = 1;
  todo->clear();
  for (std::size_t k = 0; k < games.size(); ++k)
    if (!raced[k]) todo->push_back(games[k]);
  return journal;
}

// Races `games` (the tournament's, less those a journal kept) and returns their records, each
// appended to `journal` (if any) in the step it ended. `done_before` races of `total` were
// raced before (progress counts them).
std::vector<RaceRecord> race_games(const TournamentOptions& o, const std::vector<Entry>& entries,
                                   std::vector<train::RunPolicy>& pol, race::RaceConfig rc,
                                   const std::vector<Game>& games, long done_before, long total,
                                   const std::function<void(long, long)>& progress, dist::Group* group,
                                   const TournamentJournal* journal) {
  const int n_entries = static_cast<int>(entries.size());
  std::vector<RaceRecord> out;
  c10::InferenceMode inference;  // as the trainer's rollout: no autograd bookkeeping on any tensor of a race
  at::Generator gen = models::make_generator(o.seed * 31 + 7);
  const int ts = rc.team_size, n_agent = rc.n_agent();
  // One batch of envs for the whole tournament: an env whose race ends takes the next game at
  // once, so no env idles until the slowest race of a batch is over. Each game's track and start
  // come from its own stream, race r of every pairing on track r / 2 (both sides of each track
  // flown, sides swapped), and its @random draws from the race's own: the same race whatever
  // env slot it lands in, so pairings within a tournament and the same pairing in tournaments of
  // other entries race the same tracks (common random numbers for paired comparisons).
  const int n = static_cast<int>(std::min<std::size_t>(static_cast<std::size_t>(o.batch_envs), games.size()));
  // Ranks: this one races envs [lo, hi) of the n; every rank makes the same assignments, so the
  // split changes no race.
  const int world = group ? group->size() : 1, rank = group ? group->rank() : 0;
  if (n < world)
    throw io::InputError("tournament: " + std::to_string(n) + " races at once cannot be split over " +
                         std::to_string(world) + " ranks; give --batch (and races) of at least the number of ranks");
  const int lo = static_cast<int>(static_cast<long long>(n) * rank / world);
  const int hi = static_cast<int>(static_cast<long long>(n) * (rank + 1) / world);
  const int nl = hi - lo;
  rc.n_env = nl;
  race::RaceEnv env(rc, lo);
  race::BlockCounter blocks(env);
  // The @random rule's draws: the stream of the env's current race, used only at its own HL
  // decisions.
  std::vector<RandomStream> control_rng(nl, control_stream(o.seed, 0));
  std::vector<long> env_game(n, -1);  // game index raced in each env of the whole batch, -1 idle
  using Lost = std::array<int, race::kNumCauses>;
  std::vector<Lost> lost_blue(nl), lost_red(nl);  // [n_env_local][cause]
  std::vector<int> owner(static_cast<std::size_t>(nl) * n_agent, -1);  // entry flying this rank's aircraft i
  std::size_t next_game = 0;
  // Every rank makes the same assignments (global env order), its own envs' owners only.
  auto assign = [&](int eg) {
    env_game[eg] = next_game < games.size() ? static_cast<long>(next_game++) : -1;
    if (eg < lo || eg >= hi) return;
    const int e = eg - lo;
    lost_blue[e].fill(0);
    lost_red[e].fill(0);
    const Game* g = env_game[eg] >= 0 ? &games[env_game[eg]] : nullptr;
    for (int a = 0; a < n_agent; ++a) owner[e * n_agent + a] = g ? (a < ts ? g->blue : g->red) : -1;
    if (!g) return;
    env.start_race(e, track_stream_id(g->race / 2));
    control_rng[e] = control_stream(o.seed, g->race);
  };
  for (int e = 0; e < n; ++e) assign(e);
  // Aircraft rows per entry: every network acts only on the aircraft it flies.
  train::PolicyRows rows(n_entries, nl * n_agent), hl_rows(n_entries, nl * n_agent);
  rows.assign(owner);
  std::vector<std::int64_t> bins(static_cast<std::size_t>(nl) * n_agent * 3, rc.hl_center_bin());
  std::vector<float> actions(static_cast<std::size_t>(nl) * n_agent * 3, 0.0f);
  race::AutopilotPilotConfig autopilot;
  autopilot.airspeed_ftps = o.autopilot_airspeed_ftps > 0.0 ? o.autopilot_airspeed_ftps : rc.autopilot_airspeed();
  autopilot.shift_up_frac = autopilot_shift_up(o, rc);
  if (o.autopilot_on_line) autopilot.lines = &env.racing_lines();  // each race's, drawn at its start
  // Every team's HL bins from its entry's rule: the run's HL policy on the rows it flies in the
  // envs that are due, or, for a control entry, its fixed rule per team of a due env (drawn in
  // env and team order, so independent of the thread count).
  auto choose_hl_bins = [&]() {
    const HlObs obs = train::hl_obs_view(env);
    std::vector<int> hl_owner(owner);
    for (std::size_t i = 0; i < hl_owner.size(); ++i) {
      const int e = static_cast<int>(i) / n_agent;
      if (hl_owner[i] >= 0 && (!env.hl_due()[e] || !hl_override_uses_policy(entries[hl_owner[i]].hl) ||
                               is_autopilot(entries[hl_owner[i]])))
        hl_owner[i] = -1;
    }
    hl_rows.assign(hl_owner);
    for (int id = 0; id < n_entries; ++id)
      train::policy_hl_bins(pol[entries[id].policy], obs, hl_rows.rows(id), o.epsilon, gen, bins.data());
    for (int e = 0; e < nl; ++e) {
      if (env_game[lo + e] < 0 || !env.hl_due()[e]) continue;
      for (int team = 0; team < 2; ++team) {
        const Entry& en = entries[owner[e * n_agent + team * ts]];
        // The autopilot has no high level: its goals stay on the center-line (reward only).
        if (is_control(en) || is_autopilot(en))
          fixed_hl_bins(is_autopilot(en) ? HlOverride::center : en.hl, rc.hl_bins, ts, control_rng[e],
                        bins.data() + static_cast<std::size_t>(e * n_agent + team * ts) * race::kHlDims);
      }
    }
  };
  long done_games = 0, reported = 0;
  int active = n;
  std::vector<std::int64_t> ended(n, 0);  // races that ended this step, over the whole batch
  std::vector<double> t_before(nl);       // each env's race time before the step
  std::vector<RaceRecord> now;            // this rank's races that ended this step
  while (active > 0) {
    bool due = false;
    for (int e = 0; e < nl; ++e) due = due || (env.hl_due()[e] && env_game[lo + e] >= 0);
    if (due) {
      choose_hl_bins();
      env.set_hl_actions(bins.data());
    }
    const LlObs obs = train::ll_obs_view(env);
    for (int id = 0; id < n_entries; ++id) {
      if (rows.rows(id).numel() == 0) continue;
      if (is_autopilot(entries[id])) {
        race::autopilot_actions(env, autopilot, actions.data(), rows.rows(id).data_ptr<std::int64_t>(),
                                rows.rows(id).numel());
        continue;
      }
      train::greedy_ll_actions(pol[entries[id].policy], env, obs, rows.rows(id), gen, actions.data());
    }
    for (int e = 0; e < nl; ++e) t_before[e] = env.race_time_s(e);
    env.step(actions.data());
    blocks.after_step(race::block_view(env));
    std::fill(ended.begin(), ended.end(), 0);
    now.clear();
    for (int e = 0; e < nl; ++e) {
      if (env_game[lo + e] < 0) continue;
      for (int a = 0; a < n_agent; ++a)
        if (const int c = env.step_cause()[e * n_agent + a]; c != race::kCauseNone) (a < ts ? lost_blue[e] : lost_red[e])[c] += 1;
      if (!env.env_done()[e]) continue;
      const Game& g = games[env_game[lo + e]];
      RaceRecord r;
      r.pair = g.pair;
      r.blue = g.blue;
      r.red = g.red;
      r.track_seed = rc.seed;
      r.env = lo + e;
      r.race = g.race;
      r.track = g.race / 2;
      const int w = env.race_winner()[e];
      r.winner = w < 0 ? -1 : (w == 0 ? g.blue : g.red);
      r.end_reason = env.race_end()[e];
      r.duration_s = t_before[e] + rc.dt_ll_s;
      r.blue_lost = lost_blue[e];
      r.red_lost = lost_red[e];
      r.blue_blocks = blocks.race_blocks(e, 0);
      r.red_blocks = blocks.race_blocks(e, 1);
      out.push_back(r);
      now.push_back(r);
      ended[lo + e] = 1;
    }
    if (journal) journal->append(now);
    if (group) group->allreduce_sum(ended);
    bool changed = false;
    for (int eg = 0; eg < n; ++eg) {
      if (ended[eg] == 0) continue;
      ++done_games;
      assign(eg);
      active -= env_game[eg] < 0;
      changed = changed || (eg >= lo && eg < hi);
    }
    if (changed) rows.assign(owner);
    // Progress about every 1 % of the games.
    if (progress && (done_games - reported >= std::max<long>(1, total / 100) ||
                     (active == 0 && done_games != reported))) {
      reported = done_games;
      progress(done_before + done_games, total);
    }
  }
  return out;
}

}  // namespace

TournamentResult run_tournament(const TournamentOptions& o, const std::function<void(long, long)>& progress,
                                dist::Group* group, const std::function<void(const std::string&)>& say) {
  if (o.runs.empty() && !o.include_untrained) throw io::InputError("tournament: no entries");
  if (o.runs.empty()) throw io::InputError("tournament: give at least one run folder with --runs");
  TournamentResult res;
  std::vector<train::RunPolicy> pol;
  for (const std::string& r : o.runs) {
    // The same folder twice would count one run as two seeds of its variant.
    for (const std::string& q : o.runs)
      if (&q != &r && fs::weakly_canonical(q) == fs::weakly_canonical(r))
        throw io::InputError("tournament: " + r + " is given twice in --runs; list each run folder once");
    pol.push_back(train::load_policy_spec(r));
    // Races use the first run's race; every entry must have been trained for the same shapes.
    train::check_same_race_shape(pol.front(), pol.back());
    res.entries.push_back(Entry{pol.back().name, r, agents::es_variant_name(pol.back().config.hl.variant),
                                pol.back().config.seed, HlOverride::none, static_cast<int>(pol.size()) - 1});
  }
  race::RaceConfig rc = pol.front().config.race;
  if (!o.tracks_config.empty()) {
    const train::TrainConfig t = train::read_train_config(io::load_yaml_file(o.tracks_config), o.tracks_config);
    rc.track = t.race.track;
    rc.time_limit_s = t.race.time_limit_s;
  }
  if (o.goal_line_frac >= 0.0) rc.goal_line_frac = o.goal_line_frac;
  if (!std::isnan(o.goal_shift_up_frac)) rc.goal_shift_up_frac = o.goal_shift_up_frac;
  if (o.autopilot_on_line && !o.include_autopilot)
    throw io::InputError("tournament: --autopilot-on-line sets the autopilot entry's lanes; add --with-autopilot");
  if (!std::isnan(o.autopilot_shift_up_frac) && !o.include_autopilot)
    throw io::InputError("tournament: --autopilot-shift-up moves the autopilot entry's lanes; add --with-autopilot");
  if (o.autopilot_on_line && rc.goal_line_frac <= 0.0)
    throw io::InputError("tournament: --autopilot-on-line: " + pol.front().run_dir +
                         " races on the center-line (race.goal_line_frac 0); give --goal-line F for a line to fly");
  res.race = rc;
  if (o.include_untrained) {
    pol.push_back(train::untrained_policy(pol.front().config, o.seed));
    res.entries.push_back(
        Entry{"untrained", "", "untrained", o.seed, HlOverride::none, static_cast<int>(pol.size()) - 1});
  }
  if (o.include_autopilot) res.entries.push_back(Entry{"autopilot", "", "autopilot", o.seed, HlOverride::none, -1});
  // Controls: each run's own low level (same policy object) under a fixed high level.
  std::vector<HlOverride> control_rules;
  if (o.controls) control_rules.insert(control_rules.end(), {HlOverride::center, HlOverride::random});
  if (o.axis_controls)
    control_rules.insert(control_rules.end(), {HlOverride::center_x, HlOverride::center_y, HlOverride::center_z});
  for (std::size_t k = 0; k < o.runs.size(); ++k)
    for (HlOverride rule : control_rules) {
      Entry c = res.entries[k];
      c.name += std::string("@") + hl_override_name(rule);
      c.hl = rule;
      res.entries.push_back(c);
    }
  const int n_entries = static_cast<int>(res.entries.size());
  if (n_entries < 2)
    throw io::InputError("tournament: " + res.entries.front().name +
                             " is the only entry and has no opponent; give a second run, keep the untrained entry "
                             "(drop --no-untrained) or add --controls");

  std::vector<Game> games;
  int pair = 0;
  for (int i = 0; i < n_entries; ++i)
    for (int j = i + 1; j < n_entries; ++j, ++pair)
      for (int r = 0; r < o.races_per_pair; ++r)
        games.push_back(r % 2 == 0 ? Game{pair, i, j, r} : Game{pair, j, i, r});

  rc.seed = o.seed * 1000003ULL;
  const long total = static_cast<long>(games.size());
  std::vector<Game> todo = games;
  std::unique_ptr<TournamentJournal> journal;
  // A journal only where the races do not depend on the batch: one process, greedy HL.
  if (!o.journal_path.empty() && !group && o.epsilon == 0.0) {
    journal = open_journal(o, pol, games, &todo);
    if (say && !journal->note().empty()) say(journal->note());
    for (RaceRecord r : journal->kept()) {
      r.track_seed = rc.seed;
      res.races.push_back(r);
    }
  }
  if (todo.empty()) {
    if (progress) progress(total, total);
  } else {
    std::vector<RaceRecord> raced = race_games(o, res.entries, pol, rc, todo, total - static_cast<long>(todo.size()),
                                               total, progress, group, journal.get());
    res.races.insert(res.races.end(), raced.begin(), raced.end());
  }
  if (group) res.races = gather_races(*group, res.races, rc.seed);
  res.wins.assign(n_entries, std::vector<double>(n_entries, 0.0));
  res.games.assign(n_entries, std::vector<double>(n_entries, 0.0));
  for (const RaceRecord& r : res.races) {
    res.games[r.blue][r.red] += 1;
    res.games[r.red][r.blue] += 1;
    if (r.winner < 0) {
      res.wins[r.blue][r.red] += 0.5;
      res.wins[r.red][r.blue] += 0.5;
    } else {
      res.wins[r.winner][r.winner == r.blue ? r.red : r.blue] += 1;
    }
  }
  // Races finish in env order, not game order: sort for a stable races.csv.
  std::sort(res.races.begin(), res.races.end(), [](const RaceRecord& x, const RaceRecord& y) {
    return x.pair != y.pair ? x.pair < y.pair : x.race < y.race;
  });
  return res;
}

}  // namespace f16race::eval
