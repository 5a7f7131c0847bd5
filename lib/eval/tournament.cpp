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
#include "eval/tournament_games.hpp"
#include "eval/tournament_journal.hpp"
#include "eval/tournament_output.hpp"
#include "io/atomic_file.hpp"
#include "io/input_error.hpp"
#include "io/numeric_mode.hpp"
#include "train/run_numerics.hpp"
#include "io/yaml_config.hpp"
#include "race/race_env.hpp"
#include "train/run_policy.hpp"
#include "train/train_config.hpp"

namespace f16race::eval {

namespace fs = std::filesystem;

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

// Every rank's race records, on every rank: fixed-width rows of doubles (each field a small
// integer or the duration, exact in a double), padded to the longest rank's count.
std::vector<RaceRecord> gather_races(dist::Group& group, const std::vector<RaceRecord>& mine, std::uint64_t track_seed) {
  constexpr std::size_t kBase = 11, kLost = kBase + 2 * race::kNumCauses, kFields = kLost + 2 * kChoiceFields;
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
    for (int c = 0; c < kChoiceFields; ++c) {
      row[kLost + c] = r.blue_choices[c];
      row[kLost + kChoiceFields + c] = r.red_choices[c];
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
      for (int c = 0; c < kChoiceFields; ++c) {
        r.blue_choices[c] = static_cast<int>(f[kLost + c]);
        r.red_choices[c] = static_cast<int>(f[kLost + kChoiceFields + c]);
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

// Every entry of the tournament, in TournamentResult::entries order, with the policies they fly.
void add_entries(const TournamentOptions& o, std::vector<train::RunPolicy>* pol, std::vector<Entry>* entries) {
  for (const std::string& r : o.runs) {
    // The same folder twice would count one run as two seeds of its variant.
    for (const std::string& q : o.runs)
      if (&q != &r && fs::weakly_canonical(q) == fs::weakly_canonical(r))
        throw io::InputError("tournament: " + r + " is given twice in --runs; list each run folder once");
    pol->push_back(train::load_policy_spec(r));
    // Races use the first run's race; every entry must have been trained for the same shapes.
    train::check_same_race_shape(pol->front(), pol->back());
    entries->push_back(Entry{pol->back().name, r, agents::es_variant_name(pol->back().config.hl.variant),
                             pol->back().config.seed, HlOverride::none, static_cast<int>(pol->size()) - 1});
  }
  if (o.include_untrained) {
    pol->push_back(train::untrained_policy(pol->front().config, o.seed));
    entries->push_back(Entry{"untrained", "", "untrained", o.seed, HlOverride::none, static_cast<int>(pol->size()) - 1});
  }
  if (o.include_autopilot) entries->push_back(Entry{"autopilot", "", "autopilot", o.seed, HlOverride::none, -1});
  // Controls: each run's own low level (same policy object) under a fixed high level.
  std::vector<HlOverride> control_rules;
  if (o.controls) control_rules.insert(control_rules.end(), {HlOverride::center, HlOverride::random});
  if (o.axis_controls)
    control_rules.insert(control_rules.end(), {HlOverride::center_x, HlOverride::center_y, HlOverride::center_z});
  for (std::size_t k = 0; k < o.runs.size(); ++k)
    for (HlOverride rule : control_rules) {
      Entry c = (*entries)[k];
      c.name += std::string("@") + hl_override_name(rule);
      c.hl = rule;
      entries->push_back(c);
    }
  if (entries->size() < 2)
    throw io::InputError("tournament: " + entries->front().name +
                         " is the only entry and has no opponent; give a second run, keep the untrained entry "
                         "(drop --no-untrained) or add --controls");
}

// The runs' numeric modes in one line when they differ (an ensemble A+B+C counts each of its runs).
std::string numerics_note(const std::vector<std::string>& runs) {
  std::vector<std::pair<std::string, io::RunNumerics>> seen;
  bool differ = false;
  for (const std::string& spec : runs) {
    std::stringstream parts(spec);
    for (std::string run; std::getline(parts, run, '+');) {
      seen.emplace_back(run, train::run_numerics(run));
      differ |= !io::numerics_difference(seen.front().second, seen.back().second).empty();
    }
  }
  if (!differ) return "";
  std::string note = "the runs were trained in different numeric modes, so their winrates also compare kernels:";
  for (const auto& [run, n] : seen) note += " " + run + " " + io::describe(n) + ";";
  note.back() = '.';
  return note;
}

// The first run's race with the options' tracks, time limit and goal placement.
race::RaceConfig tournament_race(const TournamentOptions& o, const train::RunPolicy& first) {
  race::RaceConfig rc = first.config.race;
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
    throw io::InputError("tournament: --set race.autopilot_shift_up_frac moves the autopilot entry's lanes; add --with-autopilot");
  if (o.autopilot_on_line && rc.goal_line_frac <= 0.0)
    throw io::InputError("tournament: --autopilot-on-line: " + first.run_dir +
                         " races on the center-line (race.goal_line_frac 0); give --set race.goal_line_frac=F for a line to fly");
  return rc;
}

// Whether entries i and j race each other: always, but with controls_own_run a control only its own run.
bool pairing_raced(const std::vector<Entry>& entries, int i, int j, bool controls_own_run) {
  if (!controls_own_run) return true;
  const Entry &a = entries[i], &b = entries[j];
  auto own_run = [](const Entry& control, const Entry& other) {
    return !is_control(other) && other.policy == control.policy && !is_untrained(other);
  };
  if (is_control(a) && !own_run(a, b)) return false;
  if (is_control(b) && !own_run(b, a)) return false;
  return true;
}

// Every pairing i < j that races, races_per_pair races each, sides swapped on odd races.
std::vector<Game> round_robin_games(const std::vector<Entry>& entries, int races_per_pair, bool controls_own_run) {
  std::vector<Game> games;
  const int n = static_cast<int>(entries.size());
  int pair = 0;
  for (int i = 0; i < n; ++i)
    for (int j = i + 1; j < n; ++j) {
      if (!pairing_raced(entries, i, j, controls_own_run)) continue;
      for (int r = 0; r < races_per_pair; ++r)
        games.push_back(r % 2 == 0 ? Game{pair, i, j, r} : Game{pair, j, i, r});
      ++pair;
    }
  return games;
}

// Wins and games per ordered pair of entries (draws count half), and races.csv's stable order.
void tally(TournamentResult* res) {
  const std::size_t n = res->entries.size();
  res->wins.assign(n, std::vector<double>(n, 0.0));
  res->games.assign(n, std::vector<double>(n, 0.0));
  for (const RaceRecord& r : res->races) {
    res->games[r.blue][r.red] += 1;
    res->games[r.red][r.blue] += 1;
    if (r.winner < 0) {
      res->wins[r.blue][r.red] += 0.5;
      res->wins[r.red][r.blue] += 0.5;
    } else {
      res->wins[r.winner][r.winner == r.blue ? r.red : r.blue] += 1;
    }
  }
  // Races finish in env order, not game order.
  std::sort(res->races.begin(), res->races.end(), [](const RaceRecord& x, const RaceRecord& y) {
    return x.pair != y.pair ? x.pair < y.pair : x.race < y.race;
  });
}

}  // namespace

TournamentResult run_tournament(const TournamentOptions& o, const std::function<void(long, long)>& progress,
                                dist::Group* group, const std::function<void(const std::string&)>& say) {
  if (o.runs.empty() && !o.include_untrained) throw io::InputError("tournament: no entries");
  if (o.runs.empty()) throw io::InputError("tournament: give at least one run folder with --runs");
  TournamentResult res;
  std::vector<train::RunPolicy> pol;
  add_entries(o, &pol, &res.entries);
  res.numerics_note = numerics_note(o.runs);
  if (say && !res.numerics_note.empty()) say("tournament: warning: " + res.numerics_note);
  race::RaceConfig rc = tournament_race(o, pol.front());
  res.race = rc;
  if (o.controls_own_run && !o.controls && !o.axis_controls)
    throw io::InputError("tournament: --controls-own-run pairs each control with its run; add --controls or --axis-controls");
  const std::vector<Game> games = round_robin_games(res.entries, o.races_per_pair, o.controls_own_run);
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
    RaceGamesInputs in;
    in.options = &o;
    in.entries = &res.entries;
    in.policies = &pol;
    in.race = rc;
    in.games = &todo;  // the tournament's games less those a journal kept
    in.done_before = total - static_cast<long>(todo.size());
    in.total = total;
    in.progress = progress;
    in.group = group;
    in.journal = journal.get();
    const std::vector<RaceRecord> raced = race_games(in);
    res.races.insert(res.races.end(), raced.begin(), raced.end());
  }
  if (group) res.races = gather_races(*group, res.races, rc.seed);
  tally(&res);
  return res;
}

}  // namespace f16race::eval
