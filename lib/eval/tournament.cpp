#include "eval/tournament.hpp"

#include <torch/torch.h>
#include <yaml-cpp/yaml.h>

#include <algorithm>
#include <cmath>
#include <filesystem>
#include <fstream>
#include <map>
#include <memory>
#include <set>
#include <sstream>
#include <stdexcept>

#include "eval/statistics.hpp"
#include "io/atomic_file.hpp"
#include "io/csv_table.hpp"
#include "io/input_error.hpp"
#include "race/block_events.hpp"
#include "io/plot.hpp"
#include "io/yaml_config.hpp"
#include "race/race_env.hpp"
#include "train/obs_views.hpp"
#include "train/policy_rows.hpp"
#include "train/run_policy.hpp"
#include "train/train_config.hpp"

namespace f16race::eval {

namespace fs = std::filesystem;
using models::HlObs;
using models::LlObs;

const char* hl_override_name(HlOverride rule) {
  switch (rule) {
    case HlOverride::center:
      return "center";
    case HlOverride::random:
      return "random";
    case HlOverride::none:
      break;
  }
  return "policy";
}

std::pair<std::string, HlOverride> parse_entry_spec(const std::string& spec) {
  for (HlOverride rule : {HlOverride::center, HlOverride::random}) {
    const std::string suffix = std::string("@") + hl_override_name(rule);
    if (spec.size() > suffix.size() && spec.compare(spec.size() - suffix.size(), suffix.size(), suffix) == 0)
      return {spec.substr(0, spec.size() - suffix.size()), rule};
  }
  // RUN@something else is a typo of a rule, not a folder name (which would fail as "not a run").
  const auto at = spec.rfind('@');
  if (at != std::string::npos && at > 0 && spec.find('/', at) == std::string::npos && !std::filesystem::exists(spec))
    throw io::InputError(spec + ": unknown high-level rule '" + spec.substr(at) +
                             "'; use RUN, RUN@center or RUN@random");
  return {spec, HlOverride::none};
}

void fixed_hl_bins(HlOverride rule, int hl_bins, int n_aircraft, race::RandomStream& rng, std::int64_t* out) {
  const std::size_t n = static_cast<std::size_t>(n_aircraft) * race::kHlDims;
  switch (rule) {
    case HlOverride::center:
      std::fill(out, out + n, static_cast<std::int64_t>(hl_bins / 2));
      return;
    case HlOverride::random:
      for (std::size_t k = 0; k < n; ++k) out[k] = rng.below(hl_bins);
      return;
    case HlOverride::none:
      break;
  }
  throw std::invalid_argument("fixed_hl_bins: HlOverride::none means the run's own HL policy, not a fixed rule");
}

race::RandomStream control_stream(std::uint64_t seed, int env) {
  // Not the (seed * 1000003, env) streams that draw the tracks: its own ids under the plain seed.
  return race::RandomStream(seed, 0xC0470000ULL + static_cast<std::uint64_t>(env));
}

bool in_variant_statistics(const Entry& entry, const TournamentOptions& options) {
  if (is_control(entry)) return false;
  if (is_untrained(entry)) return options.untrained_in_statistics;
  return true;
}

namespace {

struct Game {
  int pair, blue, red;
};

}  // namespace

TournamentResult run_tournament(const TournamentOptions& o, const std::function<void(long, long)>& progress) {
  if (o.runs.empty() && !o.include_untrained) throw io::InputError("tournament: no entries");
  if (o.runs.empty()) throw io::InputError("tournament: give at least one run folder with --runs");
  TournamentResult res;
  std::vector<train::RunPolicy> pol;
  for (const std::string& r : o.runs) {
    // The same folder twice would count one run as two seeds of its variant.
    for (const std::string& q : o.runs)
      if (&q != &r && fs::weakly_canonical(q) == fs::weakly_canonical(r))
        throw io::InputError("tournament: " + r + " is given twice in --runs; list each run folder once");
    pol.push_back(train::load_run_policy(r));
    // Races use the first run's race; every entry must have been trained for the same shapes.
    train::check_same_race_shape(pol.front(), pol.back());
    res.entries.push_back(Entry{pol.back().name, r, agents::es_variant_name(pol.back().config.hl.variant),
                                pol.back().config.seed, HlOverride::none, static_cast<int>(pol.size()) - 1});
  }
  race::RaceConfig rc = pol.front().config.race;
  if (o.include_untrained) {
    pol.push_back(train::untrained_policy(pol.front().config, o.seed));
    res.entries.push_back(
        Entry{"untrained", "", "untrained", o.seed, HlOverride::none, static_cast<int>(pol.size()) - 1});
  }
  // Controls: each run's own low level (same policy object) under a fixed high level.
  if (o.controls)
    for (std::size_t k = 0; k < o.runs.size(); ++k)
      for (HlOverride rule : {HlOverride::center, HlOverride::random}) {
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
  res.wins.assign(n_entries, std::vector<double>(n_entries, 0.0));
  res.games.assign(n_entries, std::vector<double>(n_entries, 0.0));

  std::vector<Game> games;
  int pair = 0;
  for (int i = 0; i < n_entries; ++i)
    for (int j = i + 1; j < n_entries; ++j, ++pair)
      for (int r = 0; r < o.races_per_pair; ++r) games.push_back(r % 2 == 0 ? Game{pair, i, j} : Game{pair, j, i});

  torch::NoGradGuard no_grad;
  at::Generator gen = models::make_generator(o.seed * 31 + 7);
  const int ts = rc.team_size, n_agent = rc.n_agent();
  // One batch of envs for the whole tournament: an env whose race ends takes the next game at
  // once (its auto-reset already drew a fresh track and start), so no env idles until the
  // slowest race of a batch is over.
  const int n = static_cast<int>(std::min<std::size_t>(static_cast<std::size_t>(o.batch_envs), games.size()));
  rc.n_env = n;
  rc.seed = o.seed * 1000003ULL;
  race::RaceEnv env(rc);
  race::BlockCounter blocks(env);
  // The @random rule's draws: one stream per env, used only at that env's own HL decisions.
  std::vector<race::RandomStream> control_rng;
  for (int e = 0; e < n; ++e) control_rng.push_back(control_stream(o.seed, e));
  std::vector<long> env_game(n, -1);  // game index raced in each env, -1 idle
  std::vector<int> race_in_env(n, 0);
  std::vector<int> out_blue(n, 0), out_red(n, 0);
  std::vector<int> owner(static_cast<std::size_t>(n) * n_agent, -1);  // entry flying aircraft i
  std::size_t next_game = 0;
  auto assign = [&](int e) {
    env_game[e] = next_game < games.size() ? static_cast<long>(next_game++) : -1;
    out_blue[e] = out_red[e] = 0;
    for (int a = 0; a < n_agent; ++a) {
      const Game* g = env_game[e] >= 0 ? &games[env_game[e]] : nullptr;
      owner[e * n_agent + a] = g ? (a < ts ? g->blue : g->red) : -1;
    }
  };
  for (int e = 0; e < n; ++e) assign(e);
  // Aircraft rows per entry: every network acts only on the aircraft it flies.
  train::PolicyRows rows(n_entries, n * n_agent), hl_rows(n_entries, n * n_agent);
  rows.assign(owner);
  std::vector<std::int64_t> bins(static_cast<std::size_t>(n) * n_agent * 3, rc.hl_center_bin());
  std::vector<float> actions(static_cast<std::size_t>(n) * n_agent * 3, 0.0f);
  // Every team's HL bins from its entry's rule: the run's HL policy on the rows it flies in the
  // envs that are due, or, for a control entry, its fixed rule per team of a due env (drawn in
  // env and team order, so independent of the thread count).
  auto choose_hl_bins = [&]() {
    const HlObs obs = train::hl_obs_view(env);
    std::vector<int> hl_owner(owner);
    for (std::size_t i = 0; i < hl_owner.size(); ++i) {
      const int e = static_cast<int>(i) / n_agent;
      if (hl_owner[i] >= 0 && (!env.hl_due()[e] || is_control(res.entries[hl_owner[i]]))) hl_owner[i] = -1;
    }
    hl_rows.assign(hl_owner);
    for (int id = 0; id < n_entries; ++id)
      if (hl_rows.rows(id).numel() > 0)
        train::scatter_rows(
            hl_rows.rows(id),
            pol[res.entries[id].policy].hl->act(models::index_rows(obs, hl_rows.rows(id)), o.epsilon, gen).bins,
            bins.data());
    for (int e = 0; e < n; ++e) {
      if (env_game[e] < 0 || !env.hl_due()[e]) continue;
      for (int team = 0; team < 2; ++team) {
        const Entry& en = res.entries[owner[e * n_agent + team * ts]];
        if (is_control(en))
          fixed_hl_bins(en.hl, rc.hl_bins, ts, control_rng[e],
                        bins.data() + static_cast<std::size_t>(e * n_agent + team * ts) * race::kHlDims);
      }
    }
  };
  long done_games = 0, reported = 0;
  int active = n;
  while (active > 0) {
    bool due = false;
    for (int e = 0; e < n; ++e) due = due || (env.hl_due()[e] && env_game[e] >= 0);
    if (due) {
      choose_hl_bins();
      env.set_hl_actions(bins.data());
    }
    const LlObs obs = train::ll_obs_view(env);
    for (int id = 0; id < n_entries; ++id)
      if (rows.rows(id).numel() > 0)  // greedy: the Gaussian's mean, not a sample
        train::scatter_rows(
            rows.rows(id),
            pol[res.entries[id].policy].ll->act(models::index_rows(obs, rows.rows(id)), gen, false).mean,
            actions.data());
    std::vector<double> t_before(n);
    for (int e = 0; e < n; ++e) t_before[e] = env.race_time_s(e);
    env.step(actions.data());
    blocks.after_step(race::block_view(env));
    bool changed = false;
    for (int e = 0; e < n; ++e) {
      if (env_game[e] < 0) continue;
      for (int a = 0; a < n_agent; ++a)
        if (env.step_cause()[e * n_agent + a] != race::kCauseNone) (a < ts ? out_blue[e] : out_red[e]) += 1;
      if (!env.env_done()[e]) continue;
      const Game& g = games[env_game[e]];
      RaceRecord r;
      r.pair = g.pair;
      r.blue = g.blue;
      r.red = g.red;
      r.track_seed = rc.seed;
      r.env = e;
      r.race_in_env = race_in_env[e]++;
      const int w = env.race_winner()[e];
      r.winner = w < 0 ? -1 : (w == 0 ? g.blue : g.red);
      r.end_reason = env.race_end()[e];
      r.duration_s = t_before[e] + rc.dt_ll_s;
      r.blue_out = out_blue[e];
      r.red_out = out_red[e];
      r.blue_blocks = blocks.race_blocks(e, 0);
      r.red_blocks = blocks.race_blocks(e, 1);
      res.races.push_back(r);
      res.games[g.blue][g.red] += 1;
      res.games[g.red][g.blue] += 1;
      if (r.winner < 0) {
        res.wins[g.blue][g.red] += 0.5;
        res.wins[g.red][g.blue] += 0.5;
      } else {
        res.wins[r.winner][r.winner == g.blue ? g.red : g.blue] += 1;
      }
      ++done_games;
      assign(e);
      active -= env_game[e] < 0;
      changed = true;
    }
    if (changed) rows.assign(owner);
    // Progress about every 1 % of the games.
    if (progress && (done_games - reported >= std::max<long>(1, static_cast<long>(games.size()) / 100) ||
                     (active == 0 && done_games != reported))) {
      reported = done_games;
      progress(done_games, static_cast<long>(games.size()));
    }
  }
  // Races finish in env order, not game order: sort for a stable races.csv.
  std::stable_sort(res.races.begin(), res.races.end(), [](const RaceRecord& x, const RaceRecord& y) {
    return x.env != y.env ? x.env < y.env : x.race_in_env < y.race_in_env;
  });
  return res;
}

namespace {

std::string json_escape(const std::string& s) {
  std::string o;
  for (char c : s) o += (c == '"' || c == '\\') ? std::string("\\") + c : std::string(1, c);
  return o;
}
std::string json_string(const std::string& s) { return "\"" + json_escape(s) + "\""; }
// JSON has no NaN: a statistic without data is null.
std::string json_number(double v) { return std::isfinite(v) ? io::format_double(v) : "null"; }

std::string fixed3(double v) {
  char b[32];
  std::snprintf(b, sizeof b, "%.3f", v);
  return b;
}

// A square winrate matrix (row vs column) as coloured cells with their values written in:
// `file` has columns column,row,winrate,text. Boxes rather than `with image`, which needs 2 x 2.
io::PlotPanel matrix_panel(const std::string& title, const std::string& what, const std::string& file,
                           const std::vector<std::string>& names) {
  std::string tics;
  for (std::size_t i = 0; i < names.size(); ++i) tics += (i ? ", \"" : "\"") + names[i] + "\" " + std::to_string(i);
  const std::string hi = std::to_string(static_cast<double>(names.size()) - 0.5);
  // Row 0 at the top, as in the tables of summary.md.
  io::PlotPanel p{title, "column " + what, "row " + what, {},
                  "set cbrange [0:1]\nset palette defined (0 '#b2182b', 0.5 '#f7f7f7', 1 '#2166ac')\nset grid noxtics "
                  "noytics\nset size square\nset xrange [-0.5:" + hi + "]\nset yrange [" + hi + ":-0.5]\nset xtics (" +
                      tics + ") rotate by 30 right\nset ytics (" + tics + ")\nset style fill solid 1.0 noborder"};
  p.series.push_back({file, "1:2:(0.5):(0.5):3", "boxxyerror fc palette", "", ""});
  p.series.push_back({file, "1:2:4", "labels font 'Sans,9'", "", ""});
  return p;
}

// column,row,winrate,text of a k x k matrix for matrix_panel.
void write_matrix_csv(const std::string& path, const std::vector<std::vector<double>>& m) {
  std::vector<std::vector<double>> cols(3);
  std::vector<std::vector<std::string>> text(1);
  for (std::size_t i = 0; i < m.size(); ++i)
    for (std::size_t j = 0; j < m.size(); ++j) {
      cols[0].push_back(static_cast<double>(j));
      cols[1].push_back(static_cast<double>(i));
      cols[2].push_back(m[i][j]);
      text[0].push_back(std::isfinite(m[i][j]) ? fixed3(m[i][j]) : "-");
    }
  io::write_csv(path, {"column", "row", "winrate"}, cols, {"text"}, text);
}

std::string hl_description(HlOverride rule) {
  switch (rule) {
    case HlOverride::center:
      return "fixed: middle bin";
    case HlOverride::random:
      return "fixed: uniform random bins";
    case HlOverride::none:
      break;
  }
  return "policy";
}

}  // namespace

std::string write_tournament_report(const TournamentResult& r, const TournamentOptions& o) {
  std::string summary_md;
  fs::create_directories(o.out_dir);
  const int n = static_cast<int>(r.entries.size());
  // races.csv
  {
    std::vector<std::vector<double>> cols(8);
    std::vector<double> durations, race_idx, blue_blocks, red_blocks;
    std::vector<std::vector<std::string>> names(3);
    for (const RaceRecord& x : r.races) {
      cols[0].push_back(x.pair);
      cols[1].push_back(static_cast<double>(r.entries[x.blue].seed));
      cols[2].push_back(static_cast<double>(r.entries[x.red].seed));
      cols[3].push_back(static_cast<double>(x.track_seed));
      cols[4].push_back(x.env);
      race_idx.push_back(x.race_in_env);
      cols[5].push_back(x.end_reason);
      durations.push_back(x.duration_s);
      cols[6].push_back(x.blue_out);
      cols[7].push_back(x.red_out);
      blue_blocks.push_back(x.blue_blocks);
      red_blocks.push_back(x.red_blocks);
      names[0].push_back(r.entries[x.blue].name);
      names[1].push_back(r.entries[x.red].name);
      names[2].push_back(x.winner < 0 ? "draw" : r.entries[x.winner].name);
    }
    cols.push_back(durations);
    cols.push_back(race_idx);
    cols.push_back(blue_blocks);
    cols.push_back(red_blocks);
    io::write_csv(o.out_dir + "/races.csv",
                  {"pair", "blue_seed", "red_seed", "track_stream_seed", "track_stream_env", "end_reason",
                   "blue_terminated", "red_terminated", "duration_s", "track_stream_race", "blue_blocks", "red_blocks"},
                  cols, {"blue", "red", "winner"}, names);
  }
  // pairings.csv and the entry heatmap data (row entry's winrate against the column entry).
  std::vector<std::vector<double>> rate(n, std::vector<double>(n, std::nan("")));
  {
    std::vector<std::vector<double>> cols(6);
    std::vector<std::vector<std::string>> names(2);
    for (int i = 0; i < n; ++i)
      for (int j = 0; j < n; ++j) {
        if (i == j || r.games[i][j] == 0) continue;
        rate[i][j] = r.wins[i][j] / r.games[i][j];
        const Interval ci = wilson_interval(r.wins[i][j], r.games[i][j]);
        names[0].push_back(r.entries[i].name);
        names[1].push_back(r.entries[j].name);
        cols[0].push_back(i);
        cols[1].push_back(j);
        cols[2].push_back(rate[i][j]);
        cols[3].push_back(r.games[i][j]);
        cols[4].push_back(ci.lo);
        cols[5].push_back(ci.hi);
      }
    io::write_csv(o.out_dir + "/pairings.csv", {"row", "column", "winrate", "races", "wilson95_lo", "wilson95_hi"}, cols,
                  {"row_entry", "column_entry"}, names);
  }
  // Every entry (controls and untrained included) against all the others: winrate (draws count
  // half) with a Wilson score 95 % interval over its races, so single runs can be compared too.
  std::vector<double> entry_races(n, 0.0), entry_blocks(n, 0.0);
  std::vector<Interval> entry_rate(n);
  for (const RaceRecord& x : r.races) {
    entry_blocks[x.blue] += x.blue_blocks;
    entry_blocks[x.red] += x.red_blocks;
  }
  const auto per_race = [](double count, double races) { return races > 0 ? count / races : std::nan(""); };
  std::vector<bool> counted(n);
  std::vector<std::string> excluded;
  for (int i = 0; i < n; ++i) {
    double w = 0;
    for (int j = 0; j < n; ++j) {
      w += r.wins[i][j];
      entry_races[i] += r.games[i][j];
    }
    entry_rate[i] = wilson_interval(w, entry_races[i]);
    counted[i] = in_variant_statistics(r.entries[i], o);
    if (!counted[i]) excluded.push_back(r.entries[i].name);
  }
  // Per variant, over the entries counted in the statistics only (no controls; "untrained" only
  // with untrained_in_statistics): mean total winrate +- std over its runs (seeds), and the IQM
  // of its pairing winrates against every counted entry of the other variants with a
  // stratified-bootstrap 95 % CI.
  std::map<std::string, std::vector<int>> by_variant;
  for (int i = 0; i < n; ++i)
    if (counted[i]) by_variant[r.entries[i].variant].push_back(i);
  struct Row {
    std::string variant;
    int runs;
    double mean, std;
    Interval iqm;
    double races;
    double blocks_per_race;  // blocks by the variant's runs in all their races / those races
  };
  std::vector<Row> rows;
  for (const auto& [variant, members] : by_variant) {
    std::vector<int> opponents;
    for (int j = 0; j < n; ++j)
      if (counted[j] && r.entries[j].variant != variant) opponents.push_back(j);
    if (opponents.empty()) continue;
    std::vector<double> totals;
    std::vector<std::vector<double>> scores;
    double races = 0;
    for (int i : members) {
      double w = 0, g = 0;
      std::vector<double> s;
      for (int j : opponents) {
        w += r.wins[i][j];
        g += r.games[i][j];
        s.push_back(r.games[i][j] > 0 ? r.wins[i][j] / r.games[i][j] : 0.5);
      }
      totals.push_back(g > 0 ? w / g : std::nan(""));
      scores.push_back(s);
      races += g;
    }
    double member_blocks = 0, member_races = 0;
    for (int i : members) {
      member_blocks += entry_blocks[i];
      member_races += entry_races[i];
    }
    rows.push_back(Row{variant, static_cast<int>(members.size()), mean(totals), stddev(totals),
                       iqm_with_ci(scores, o.bootstrap_replicates, 0.05, o.seed), races,
                       per_race(member_blocks, member_races)});
  }
  // Variant vs variant (the paper's Fig. 3, right): mean winrate of the row variant's counted
  // entries against the column variant's over all their pairings. Same variant: pairs of
  // different entries (0.5 by symmetry when both sides played equally often); none: NaN.
  std::vector<std::string> variants;
  for (const auto& kv : by_variant) variants.push_back(kv.first);
  const std::size_t nv = variants.size();
  std::vector<std::vector<double>> vrate(nv, std::vector<double>(nv, std::nan("")));
  std::vector<std::vector<int>> vpairs(nv, std::vector<int>(nv, 0));
  for (std::size_t a = 0; a < nv; ++a)
    for (std::size_t b = 0; b < nv; ++b) {
      std::vector<double> s;
      for (int i : by_variant[variants[a]])
        for (int j : by_variant[variants[b]])
          if (i != j && r.games[i][j] > 0) s.push_back(rate[i][j]);
      vpairs[a][b] = static_cast<int>(s.size());
      if (!s.empty()) vrate[a][b] = mean(s);
    }
  {
    std::ostringstream js;
    js << "{\n  \"races_per_pair\": " << o.races_per_pair << ",\n  \"epsilon\": " << o.epsilon
       << ",\n  \"bootstrap_replicates\": " << o.bootstrap_replicates << ",\n  \"seed\": " << o.seed
       << ",\n  \"untrained_in_statistics\": " << (o.untrained_in_statistics ? "true" : "false")
       << ",\n  \"excluded_from_variant_statistics\": [";
    for (std::size_t k = 0; k < excluded.size(); ++k) js << (k ? ", " : "") << json_string(excluded[k]);
    js << "],\n  \"variants\": [\n";
    for (std::size_t k = 0; k < rows.size(); ++k) {
      const Row& x = rows[k];
      js << "    {\"variant\": " << json_string(x.variant) << ", \"runs\": " << x.runs << ", \"races\": " << x.races
         << ", \"winrate_mean\": " << json_number(x.mean) << ", \"winrate_std\": " << json_number(x.std)
         << ", \"iqm\": " << json_number(x.iqm.point) << ", \"iqm_ci95\": [" << json_number(x.iqm.lo) << ", "
         << json_number(x.iqm.hi) << "], \"blocks_per_race\": " << json_number(x.blocks_per_race) << "}"
         << (k + 1 < rows.size() ? "," : "") << "\n";
    }
    js << "  ],\n  \"entries\": [\n";
    for (int i = 0; i < n; ++i) {
      const Entry& e = r.entries[i];
      js << "    {\"name\": " << json_string(e.name) << ", \"variant\": " << json_string(e.variant)
         << ", \"hl\": " << json_string(hl_override_name(e.hl)) << ", \"seed\": " << e.seed
         << ", \"in_variant_statistics\": " << (counted[i] ? "true" : "false") << ", \"races\": " << entry_races[i]
         << ", \"winrate\": " << json_number(entry_rate[i].point) << ", \"wilson95\": ["
         << json_number(entry_rate[i].lo) << ", " << json_number(entry_rate[i].hi)
         << "], \"blocks_per_race\": " << json_number(per_race(entry_blocks[i], entry_races[i])) << "}"
         << (i + 1 < n ? "," : "")
         << "\n";
    }
    js << "  ],\n  \"pairings\": [";
    bool first = true;
    for (int i = 0; i < n; ++i)
      for (int j = 0; j < n; ++j) {
        if (i == j || r.games[i][j] == 0) continue;
        const Interval ci = wilson_interval(r.wins[i][j], r.games[i][j]);
        js << (first ? "\n" : ",\n") << "    {\"row\": " << json_string(r.entries[i].name)
           << ", \"col\": " << json_string(r.entries[j].name) << ", \"races\": " << r.games[i][j]
           << ", \"winrate\": " << json_number(rate[i][j]) << ", \"wilson95\": [" << json_number(ci.lo) << ", "
           << json_number(ci.hi) << "]}";
        first = false;
      }
    js << "\n  ],\n  \"variant_vs_variant\": {\"variants\": [";
    for (std::size_t a = 0; a < nv; ++a) js << (a ? ", " : "") << json_string(variants[a]);
    js << "], \"winrate\": [";
    for (std::size_t a = 0; a < nv; ++a) {
      js << (a ? ", [" : "[");
      for (std::size_t b = 0; b < nv; ++b) js << (b ? ", " : "") << json_number(vrate[a][b]);
      js << "]";
    }
    js << "], \"pairings\": [";
    for (std::size_t a = 0; a < nv; ++a) {
      js << (a ? ", [" : "[");
      for (std::size_t b = 0; b < nv; ++b) js << (b ? ", " : "") << vpairs[a][b];
      js << "]";
    }
    js << "]}\n}\n";
    io::write_file_atomic(o.out_dir + "/summary.json", js.str());

    std::ostringstream md;
    md << "# Tournament\n\n" << o.races_per_pair << " races per pair (sides swapped in half), HL epsilon " << o.epsilon
       << ", " << r.races.size() << " races in all.\n\n"
       << "| variant | runs | races | total winrate (mean +- std over runs) | IQM of pairing winrates [95% CI] "
          "| blocks per race |\n"
       << "|---|---|---|---|---|---|\n";
    char buf[512];
    for (const Row& x : rows) {
      std::snprintf(buf, sizeof buf, "| %s | %d | %.0f | %.3f +- %.3f | %.3f [%.3f, %.3f] | %.3f |\n", x.variant.c_str(),
                    x.runs, x.races, x.mean, x.std, x.iqm.point, x.iqm.lo, x.iqm.hi, x.blocks_per_race);
      md << buf;
    }
    if (rows.empty())
      md << "| (every entry counted in the statistics has the same variant: no other variant to compare with) "
            "| | | | | |\n";
    md << "\nTotal winrate: all races of a run against the entries of the other variants (draws count half). IQM: "
          "25% trimmed mean over the run x opponent winrates; CI: percentile bootstrap resampling runs within "
          "each opponent (rliable's stratified bootstrap). Blocks per race: events, per race of the entry, where an aircraft of its team "
          "sat in front of an opponent (<= 1000 ft ahead along the track, <= 300 ft away in the tube's cross-section) "
          "and within 5 s that opponent was taken out or passed by a teammate while still behind the blocker (docs/race.md, "
          "\"Blocks\"), counted per team and race.\n\n";
    if (excluded.empty()) {
      md << "Every entry counts in the variant statistics.\n\n";
    } else {
      md << "Excluded from the variant statistics and the variant-vs-variant table (listed below, and in "
            "pairings.csv and pairings.png):";
      for (std::size_t k = 0; k < excluded.size(); ++k) md << (k ? ", " : " ") << excluded[k];
      md << ".";
      bool has_untrained = false, has_control = false;
      for (int i = 0; i < n; ++i) {
        has_untrained = has_untrained || (!counted[i] && is_untrained(r.entries[i]));
        has_control = has_control || is_control(r.entries[i]);
      }
      if (has_untrained) md << " `untrained` is the networks before any update (`--with-untrained` counts it).";
      if (has_control)
        md << " `RUN@center` and `RUN@random` are controls: the run's trained low level with a fixed high level "
              "(the middle bin on every axis, or uniform random bins at every HL decision).";
      md << "\n\n";
    }
    md << "Variant vs variant: mean winrate of the row variant's entries against the column variant's over all "
          "their pairings.\n\n| row vs column |";
    for (const std::string& v : variants) md << " " << v << " |";
    md << "\n|---|";
    for (std::size_t b = 0; b < nv; ++b) md << "---|";
    md << "\n";
    for (std::size_t a = 0; a < nv; ++a) {
      md << "| " << variants[a] << " |";
      for (std::size_t b = 0; b < nv; ++b)
        md << " " << (std::isfinite(vrate[a][b]) ? fixed3(vrate[a][b]) : "-") << " |";
      md << "\n";
    }
    md << "\n| entry | variant | seed | races | winrate vs all other entries [95% Wilson CI] | blocks per race | HL "
          "| in variant statistics |\n|---|---|---|---|---|---|---|---|\n";
    for (int i = 0; i < n; ++i) {
      std::snprintf(buf, sizeof buf, "| %s | %s | %llu | %.0f | %.4f [%.4f, %.4f] | %.3f | %s | %s |\n",
                    r.entries[i].name.c_str(), r.entries[i].variant.c_str(),
                    static_cast<unsigned long long>(r.entries[i].seed), entry_races[i], entry_rate[i].point,
                    entry_rate[i].lo, entry_rate[i].hi, per_race(entry_blocks[i], entry_races[i]),
                    hl_description(r.entries[i].hl).c_str(),
                    counted[i] ? "yes" : "no");
      md << buf;
    }
    // What the trained high level adds: each run against its own controls, head to head.
    bool any_control = false;
    for (int i = 0; i < n; ++i) any_control = any_control || is_control(r.entries[i]);
    if (any_control) {
      md << "\nTrained high level vs its own controls (same low level), head to head [95% Wilson CI]:\n\n"
            "| run | races | vs RUN@center | vs RUN@random |\n|---|---|---|---|\n";
      for (int i = 0; i < n; ++i) {
        if (is_control(r.entries[i])) continue;
        std::string cells[2];
        double races = 0.0;
        for (int j = 0; j < n; ++j) {
          if (!is_control(r.entries[j]) || r.entries[j].policy != r.entries[i].policy || r.games[i][j] == 0) continue;
          const Interval ci = wilson_interval(r.wins[i][j], r.games[i][j]);
          std::snprintf(buf, sizeof buf, "%.3f [%.3f, %.3f]", ci.point, ci.lo, ci.hi);
          cells[r.entries[j].hl == HlOverride::center ? 0 : 1] = buf;
          races = r.games[i][j];
        }
        if (cells[0].empty() && cells[1].empty()) continue;
        std::snprintf(buf, sizeof buf, "| %s | %.0f | %s | %s |\n", r.entries[i].name.c_str(), races,
                      cells[0].empty() ? "-" : cells[0].c_str(), cells[1].empty() ? "-" : cells[1].c_str());
        md << buf;
      }
    }
    summary_md = md.str();
    io::write_file_atomic(o.out_dir + "/summary.md", summary_md);
  }
  // tournament.png in the layout of the paper's Fig. 3: bars with std, IQM with CI, variant vs
  // variant; pairings.png: entry vs entry, controls and untrained included.
  {
    std::vector<std::vector<double>> cols(5);
    std::vector<std::vector<std::string>> names(1);
    for (std::size_t k = 0; k < rows.size(); ++k) {
      cols[0].push_back(static_cast<double>(k));
      cols[1].push_back(rows[k].mean);
      cols[2].push_back(rows[k].std);
      cols[3].push_back(rows[k].iqm.lo);
      cols[4].push_back(rows[k].iqm.hi);
      names[0].push_back(rows[k].variant);
    }
    std::vector<double> iqm_point;
    for (const Row& x : rows) iqm_point.push_back(x.iqm.point);
    cols.push_back(iqm_point);
    io::write_csv(o.out_dir + "/variants.csv", {"index", "winrate_mean", "winrate_std", "iqm_lo", "iqm_hi", "iqm"}, cols,
                  {"variant"}, names);
    write_matrix_csv(o.out_dir + "/variant_matrix.csv", vrate);
    io::PlotSpec spec;
    spec.output = o.out_dir + "/tournament.png";
    spec.cols = 3;
    spec.width_px = 1800;
    spec.height_px = 550;
    spec.title = "Round-robin: " + std::to_string(r.races.size()) + " races";
    // With no variant to compare (one variant) the first two panels stay empty but keep their axes.
    std::string xr =
        "set xrange [-0.5:" + std::to_string(std::max<double>(1.0, static_cast<double>(rows.size())) - 0.5) + "]";
    if (rows.empty())
      xr += "\nunset xtics\nset label 1 'one variant: no other variant to compare with' at graph 0.5,0.5 center";
    io::PlotPanel bars{"Total winrate (mean, std over runs)", "", "winrate", {}, "set yrange [0:1]\nset style fill solid 0.6\nset boxwidth 0.6\n" + xr};
    bars.series.push_back({"variants.csv", "1:2:3:xtic(7)", "boxerrorbars lc rgb '#4477aa'", "", ""});
    io::PlotPanel iq{"IQM of pairing winrates, 95% CI", "", "winrate", {}, "set yrange [0:1]\n" + xr};
    iq.series.push_back({"variants.csv", "1:6:4:5:xtic(7)", "yerrorbars pt 7 ps 1.5 lc rgb '#cc3311'", "", ""});
    spec.panels = {bars, iq,
                   matrix_panel("Variant vs variant, mean pairing winrate (row vs column)", "variant",
                                "variant_matrix.csv", variants)};
    std::string msg;
    io::render_plot(spec, o.out_dir + "/tournament.gp", &msg);

    std::vector<std::string> entry_names;
    for (const Entry& e : r.entries) entry_names.push_back(e.name);
    write_matrix_csv(o.out_dir + "/heatmap.csv", rate);
    io::PlotSpec pairings;
    pairings.output = o.out_dir + "/pairings.png";
    pairings.width_px = std::max(900, 300 + 75 * n);
    pairings.height_px = std::max(750, 250 + 70 * n);
    pairings.title = "Pairing winrate, every entry: " + std::to_string(r.races.size()) + " races";
    pairings.panels = {
        matrix_panel("Winrate of the row entry against the column entry", "entry", "heatmap.csv", entry_names)};
    io::render_plot(pairings, o.out_dir + "/pairings.gp", &msg);
  }
  return summary_md;
}

}  // namespace f16race::eval
