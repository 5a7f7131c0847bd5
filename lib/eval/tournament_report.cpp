#include "eval/tournament_report.hpp"

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <filesystem>
#include <map>
#include <sstream>

#include "eval/tournament_output.hpp"
#include "race/scripted_pilot.hpp"
#include "io/atomic_file.hpp"
#include "io/csv_table.hpp"
#include "io/json_text.hpp"
#include "io/plot.hpp"

namespace f16race::eval {

namespace fs = std::filesystem;
using io::json_string;

namespace {

// JSON has no NaN: a statistic without data is null.
std::string json_number(double v) { return std::isfinite(v) ? io::format_double(v) : "null"; }

double per_race(double count, double races) { return races > 0 ? count / races : std::nan(""); }

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
  std::vector<std::vector<double>> cols(2);
  std::vector<std::vector<std::string>> text(2);
  for (std::size_t i = 0; i < m.size(); ++i)
    for (std::size_t j = 0; j < m.size(); ++j) {
      cols[0].push_back(static_cast<double>(j));
      cols[1].push_back(static_cast<double>(i));
      // A pairing that was not raced (an entry against itself) is an empty cell: gnuplot skips it.
      const bool raced = std::isfinite(m[i][j]);
      text[0].push_back(raced ? io::format_double(m[i][j]) : "");
      text[1].push_back(raced ? fixed3(m[i][j]) : "-");
    }
  io::write_csv(path, {"column", "row"}, cols, {"winrate", "text"}, text);
}

std::string hl_description(const Entry& e) {
  if (is_autopilot(e)) return "none: AeroBench's waypoint autopilot";
  return hl_override_description(e.hl);
}

// Per variant, over the entries counted in the statistics only (no controls; "untrained" only
// with untrained_in_statistics): mean total winrate +- std over its runs (seeds), and the IQM of
// its pairing winrates against every counted entry of the other variants with a
// stratified-bootstrap 95 % CI. No row when no other variant is counted.
void add_variant_row(const TournamentResult& r, const TournamentOptions& o, const std::string& variant,
                     const std::vector<int>& members, TournamentStatistics* s) {
  const int n = static_cast<int>(r.entries.size());
  std::vector<int> opponents;
  for (int j = 0; j < n; ++j)
    if (s->counted[j] && r.entries[j].variant != variant) opponents.push_back(j);
  if (opponents.empty()) return;
  std::vector<double> totals;
  std::vector<std::vector<double>> scores;
  double races = 0, member_blocks = 0, member_races = 0;
  for (int i : members) {
    double w = 0, g = 0;
    std::vector<double> sc;
    for (int j : opponents) {
      w += r.wins[i][j];
      g += r.games[i][j];
      sc.push_back(r.games[i][j] > 0 ? r.wins[i][j] / r.games[i][j] : 0.5);
    }
    totals.push_back(g > 0 ? w / g : std::nan(""));
    scores.push_back(sc);
    races += g;
    member_blocks += s->entry_blocks[i];
    member_races += s->entry_races[i];
  }
  s->rows.push_back(VariantRow{variant, static_cast<int>(members.size()), mean(totals), stddev(totals),
                               iqm_with_ci(scores, o.bootstrap_replicates, 0.05, o.seed), races,
                               per_race(member_blocks, member_races)});
}

// Variant vs variant (the paper's Fig. 3, right): mean winrate of the row variant's counted
// entries against the column variant's over all their pairings. Same variant: pairs of different
// entries (0.5 by symmetry when both sides played equally often); none: NaN.
void fill_variant_matrix(const TournamentResult& r, const std::map<std::string, std::vector<int>>& by_variant,
                         TournamentStatistics* s) {
  for (const auto& kv : by_variant) s->variants.push_back(kv.first);
  const std::size_t nv = s->variants.size();
  s->variant_rate.assign(nv, std::vector<double>(nv, std::nan("")));
  s->variant_pairs.assign(nv, std::vector<int>(nv, 0));
  for (std::size_t a = 0; a < nv; ++a)
    for (std::size_t b = 0; b < nv; ++b) {
      std::vector<double> x;
      for (int i : by_variant.at(s->variants[a]))
        for (int j : by_variant.at(s->variants[b]))
          if (i != j && r.games[i][j] > 0) x.push_back(s->rate[i][j]);
      s->variant_pairs[a][b] = static_cast<int>(x.size());
      if (!x.empty()) s->variant_rate[a][b] = mean(x);
    }
}

}  // namespace

TournamentStatistics tournament_statistics(const TournamentResult& r, const TournamentOptions& o) {
  TournamentStatistics s;
  const int n = static_cast<int>(r.entries.size());
  s.rate.assign(n, std::vector<double>(n, std::nan("")));
  for (int i = 0; i < n; ++i)
    for (int j = 0; j < n; ++j)
      if (i != j && r.games[i][j] > 0) s.rate[i][j] = r.wins[i][j] / r.games[i][j];
  // Every entry (controls and untrained included) against all the others: winrate (draws count
  // half) with a Wilson score 95 % interval over its races, so single runs can be compared too.
  s.entry_races.assign(n, 0.0);
  s.entry_blocks.assign(n, 0.0);
  s.entry_rate.assign(n, Interval{});
  s.entry_choices.assign(n, {});
  for (const RaceRecord& x : r.races) {
    s.entry_blocks[x.blue] += x.blue_blocks;
    s.entry_blocks[x.red] += x.red_blocks;
    for (int c = 0; c < kChoiceFields; ++c) {
      s.entry_choices[x.blue][c] += x.blue_choices[c];
      s.entry_choices[x.red][c] += x.red_choices[c];
    }
  }
  s.counted.assign(n, false);
  for (int i = 0; i < n; ++i) {
    double w = 0;
    for (int j = 0; j < n; ++j) {
      w += r.wins[i][j];
      s.entry_races[i] += r.games[i][j];
    }
    s.entry_rate[i] = wilson_interval(w, s.entry_races[i]);
    s.counted[i] = in_variant_statistics(r.entries[i], o);
    if (!s.counted[i]) s.excluded.push_back(r.entries[i].name);
  }
  std::map<std::string, std::vector<int>> by_variant;
  for (int i = 0; i < n; ++i)
    if (s.counted[i]) by_variant[r.entries[i].variant].push_back(i);
  for (const auto& [variant, members] : by_variant) add_variant_row(r, o, variant, members, &s);
  fill_variant_matrix(r, by_variant, &s);
  return s;
}

// One row per race; the last columns count each team's aircraft lost per termination cause.
void write_races_csv(const TournamentResult& r, const std::string& path) {
  // No env slot column: a race is the same in any slot, and a resumed tournament places its
  // games in other slots; without it races.csv is the same bytes either way.
  constexpr int kBase = 12;
  std::vector<std::vector<double>> cols(kBase + 2 * (race::kNumCauses - 1));
  std::vector<std::vector<std::string>> names(3);
  for (const RaceRecord& x : r.races) {
    const double f[kBase] = {double(x.pair),
                             double(x.race),
                             static_cast<double>(r.entries[x.blue].seed),
                             static_cast<double>(r.entries[x.red].seed),
                             static_cast<double>(x.track_seed),
                             double(x.track),
                             double(x.end_reason),
                             double(x.blue_out()),
                             double(x.red_out()),
                             x.duration_s,
                             double(x.blue_blocks),
                             double(x.red_blocks)};
    for (int c = 0; c < kBase; ++c) cols[c].push_back(f[c]);
    for (int c = 1; c < race::kNumCauses; ++c) {
      cols[kBase + c - 1].push_back(x.blue_lost[c]);
      cols[kBase + race::kNumCauses - 1 + c - 1].push_back(x.red_lost[c]);
    }
    names[0].push_back(r.entries[x.blue].name);
    names[1].push_back(r.entries[x.red].name);
    names[2].push_back(x.winner < 0 ? "draw" : r.entries[x.winner].name);
  }
  std::vector<std::string> header = {"pair",           "race",          "blue_seed",  "red_seed",    "track_seed",
                                     "track",          "end_reason",    "blue_terminated",
                                     "red_terminated", "duration_s",    "blue_blocks", "red_blocks"};
  for (const char* team : {"blue", "red"})
    for (int c = 1; c < race::kNumCauses; ++c) header.push_back(std::string(team) + "_out_" + race::cause_name(c));
  io::write_csv(path, header, cols, {"blue", "red", "winner"}, names);
}

void write_pairings_csv(const TournamentResult& r, const TournamentStatistics& s, const std::string& path) {
  const int n = static_cast<int>(r.entries.size());
  std::vector<std::vector<double>> cols(6);
  std::vector<std::vector<std::string>> names(2);
  for (int i = 0; i < n; ++i)
    for (int j = 0; j < n; ++j) {
      if (i == j || r.games[i][j] == 0) continue;
      const Interval ci = wilson_interval(r.wins[i][j], r.games[i][j]);
      names[0].push_back(r.entries[i].name);
      names[1].push_back(r.entries[j].name);
      cols[0].push_back(i);
      cols[1].push_back(j);
      cols[2].push_back(s.rate[i][j]);
      cols[3].push_back(r.games[i][j]);
      cols[4].push_back(ci.lo);
      cols[5].push_back(ci.hi);
    }
  io::write_csv(path, {"row", "column", "winrate", "races", "wilson95_lo", "wilson95_hi"}, cols,
                {"row_entry", "column_entry"}, names);
}

namespace {

// The names of the HL's goal axes in the race's goal frame.
std::array<const char*, race::kHlDims> goal_axis_names(const race::RaceConfig& rc) {
  if (rc.goal_frame == race::GoalFrame::kTrack) return {"along", "right", "up"};
  return {"north", "east", "up"};
}

// An entry's decisions, and per axis the share of them below / on / above the middle bin
// ([axis * 3 + k]; NaN without decisions): what summary.json and summary.md both report.
struct GoalChoiceShares {
  double decisions = 0.0;
  std::array<double, kChoiceFields> share{};
};

GoalChoiceShares goal_choice_shares(const std::array<double, kChoiceFields>& counts) {
  GoalChoiceShares g;
  g.decisions = counts[0] + counts[1] + counts[2];  // every decision has one of three on axis 0
  for (int k = 0; k < kChoiceFields; ++k) g.share[k] = g.decisions > 0 ? counts[k] / g.decisions : std::nan("");
  return g;
}

// {"decisions": N, "along": [below, middle, above], ...}: shares of the entry's decisions per axis.
std::string goal_choices_json(const race::RaceConfig& rc, const std::array<double, kChoiceFields>& c) {
  const GoalChoiceShares g = goal_choice_shares(c);
  std::ostringstream js;
  char buf[32];
  std::snprintf(buf, sizeof buf, "%.0f", g.decisions);
  js << "{\"decisions\": " << buf;
  const auto names = goal_axis_names(rc);
  for (int d = 0; d < race::kHlDims; ++d) {
    js << ", " << json_string(names[d]) << ": [";
    for (int k = 0; k < 3; ++k) js << (k ? ", " : "") << json_number(g.share[d * 3 + k]);
    js << "]";
  }
  js << "}";
  return js.str();
}

}  // namespace

void write_summary_json(const TournamentResult& r, const TournamentStatistics& s, const TournamentOptions& o,
                        const std::string& path) {
  const int n = static_cast<int>(r.entries.size());
  const std::size_t nv = s.variants.size();
  std::ostringstream js;
  js << "{\n  \"races_per_pair\": " << o.races_per_pair << ",\n  \"epsilon\": " << o.epsilon
     << ",\n  \"bootstrap_replicates\": " << o.bootstrap_replicates << ",\n  \"seed\": " << o.seed
     << ",\n  \"untrained_in_statistics\": " << (o.untrained_in_statistics ? "true" : "false")
     << ",\n  \"excluded_from_variant_statistics\": [";
  for (std::size_t k = 0; k < s.excluded.size(); ++k) js << (k ? ", " : "") << json_string(s.excluded[k]);
  js << "],\n  \"variants\": [\n";
  for (std::size_t k = 0; k < s.rows.size(); ++k) {
    const VariantRow& x = s.rows[k];
    js << "    {\"variant\": " << json_string(x.variant) << ", \"runs\": " << x.runs << ", \"races\": " << x.races
       << ", \"winrate_mean\": " << json_number(x.mean) << ", \"winrate_std\": " << json_number(x.std)
       << ", \"iqm\": " << json_number(x.iqm.point) << ", \"iqm_ci95\": [" << json_number(x.iqm.lo) << ", "
       << json_number(x.iqm.hi) << "], \"blocks_per_race\": " << json_number(x.blocks_per_race) << "}"
       << (k + 1 < s.rows.size() ? "," : "") << "\n";
  }
  js << "  ],\n  \"entries\": [\n";
  for (int i = 0; i < n; ++i) {
    const Entry& e = r.entries[i];
    js << "    {\"name\": " << json_string(e.name) << ", \"variant\": " << json_string(e.variant)
       << ", \"hl\": " << json_string(hl_override_name(e.hl)) << ", \"seed\": " << e.seed
       << ", \"in_variant_statistics\": " << (s.counted[i] ? "true" : "false") << ", \"races\": " << s.entry_races[i]
       << ", \"winrate\": " << json_number(s.entry_rate[i].point) << ", \"wilson95\": ["
       << json_number(s.entry_rate[i].lo) << ", " << json_number(s.entry_rate[i].hi)
       << "], \"blocks_per_race\": " << json_number(per_race(s.entry_blocks[i], s.entry_races[i]))
       << ", \"goal_choices\": " << goal_choices_json(r.race, s.entry_choices[i]) << "}" << (i + 1 < n ? "," : "")
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
         << ", \"winrate\": " << json_number(s.rate[i][j]) << ", \"wilson95\": [" << json_number(ci.lo) << ", "
         << json_number(ci.hi) << "]}";
      first = false;
    }
  js << "\n  ],\n  \"variant_vs_variant\": {\"variants\": [";
  for (std::size_t a = 0; a < nv; ++a) js << (a ? ", " : "") << json_string(s.variants[a]);
  js << "], \"winrate\": [";
  for (std::size_t a = 0; a < nv; ++a) {
    js << (a ? ", [" : "[");
    for (std::size_t b = 0; b < nv; ++b) js << (b ? ", " : "") << json_number(s.variant_rate[a][b]);
    js << "]";
  }
  js << "], \"pairings\": [";
  for (std::size_t a = 0; a < nv; ++a) {
    js << (a ? ", [" : "[");
    for (std::size_t b = 0; b < nv; ++b) js << (b ? ", " : "") << s.variant_pairs[a][b];
    js << "]";
  }
  js << "]}\n}\n";
  io::write_file_atomic(path, js.str());
}

namespace {

// The variant table (mean +- std, IQM with its CI, blocks) and how to read it.
void variant_table_md(const TournamentStatistics& s, std::ostringstream& md) {
  md << "| variant | runs | races | total winrate (mean +- std over runs) | IQM of pairing winrates [95% CI] "
        "| blocks per race |\n"
     << "|---|---|---|---|---|---|\n";
  char buf[512];
  for (const VariantRow& x : s.rows) {
    std::snprintf(buf, sizeof buf, "| %s | %d | %.0f | %.3f +- %.3f | %.3f [%.3f, %.3f] | %.3f |\n", x.variant.c_str(),
                  x.runs, x.races, x.mean, x.std, x.iqm.point, x.iqm.lo, x.iqm.hi, x.blocks_per_race);
    md << buf;
  }
  if (s.rows.empty())
    md << "| (every entry counted in the statistics has the same variant: no other variant to compare with) "
          "| | | | | |\n";
  md << "\nTotal winrate: all races of a run against the entries of the other variants (draws count half). IQM: "
        "25% trimmed mean over the run x opponent winrates; CI: percentile bootstrap resampling runs within "
        "each opponent (rliable's stratified bootstrap). Blocks per race: events, per race of the entry, where an aircraft of its team "
        "sat in front of an opponent (<= 1000 ft ahead along the track, <= 300 ft away in the tube's cross-section) "
        "and within 5 s that opponent was taken out or passed by a teammate while still behind the blocker (docs/race.md, "
        "\"Blocks\"), counted per team and race.\n\n";
}

// Which entries the variant statistics leave out, and what the special ones are.
void excluded_md(const TournamentResult& r, const TournamentStatistics& s, const TournamentOptions& o,
                 std::ostringstream& md) {
  if (s.excluded.empty()) {
    md << "Every entry counts in the variant statistics.\n\n";
    return;
  }
  md << "Excluded from the variant statistics and the variant-vs-variant table (listed below, and in "
        "pairings.csv and pairings.png):";
  for (std::size_t k = 0; k < s.excluded.size(); ++k) md << (k ? ", " : " ") << s.excluded[k];
  md << ".";
  bool has_untrained = false, has_control = false, has_autopilot = false;
  for (std::size_t i = 0; i < r.entries.size(); ++i) {
    has_untrained = has_untrained || (!s.counted[i] && is_untrained(r.entries[i]));
    has_control = has_control || is_control(r.entries[i]);
    has_autopilot = has_autopilot || is_autopilot(r.entries[i]);
  }
  if (has_untrained) md << " `untrained` is the networks before any update (`--with-untrained` counts it).";
  if (has_autopilot)
    md << " `autopilot` is classic control, no learning: AeroBench's waypoint autopilot (its gains) chasing a "
          "point "
       << race::AutopilotPilotConfig{}.lookahead_ft << " ft ahead in each aircraft's start lane at "
       << (o.autopilot_airspeed_ftps > 0.0 ? o.autopilot_airspeed_ftps : r.race.autopilot_airspeed())
       << " ft/s (its set point, race.autopilot_airspeed_ftps)";
  if (has_autopilot && autopilot_shift_up(o, r.race) != 0.0)
    md << ", its aim points moved up by " << autopilot_shift_up(o, r.race)
       << " of the tube radius (race.autopilot_shift_up_frac)";
  if (has_autopilot) md << ".";
  if (has_control)
    md << " `RUN@center` and `RUN@random` are controls: the run's trained low level with a fixed high level "
          "(the middle bin on every axis, or uniform random bins at every HL decision); `RUN@center_x`, `_y`, `_z` "
          "fly the run's own high level with that goal axis held on the middle bin.";
  md << "\n\n";
}

// Variant vs variant (the paper's Fig. 3, right), then every entry with its Wilson interval.
void matrix_and_entries_md(const TournamentResult& r, const TournamentStatistics& s, std::ostringstream& md) {
  const std::size_t nv = s.variants.size();
  md << "Variant vs variant: mean winrate of the row variant's entries against the column variant's over all "
        "their pairings.\n\n| row vs column |";
  for (const std::string& v : s.variants) md << " " << v << " |";
  md << "\n|---|";
  for (std::size_t b = 0; b < nv; ++b) md << "---|";
  md << "\n";
  for (std::size_t a = 0; a < nv; ++a) {
    md << "| " << s.variants[a] << " |";
    for (std::size_t b = 0; b < nv; ++b)
      md << " " << (std::isfinite(s.variant_rate[a][b]) ? fixed3(s.variant_rate[a][b]) : "-") << " |";
    md << "\n";
  }
  md << "\n| entry | variant | seed | races | winrate vs all other entries [95% Wilson CI] | blocks per race | HL "
        "| in variant statistics |\n|---|---|---|---|---|---|---|---|\n";
  char buf[512];
  for (std::size_t i = 0; i < r.entries.size(); ++i) {
    std::snprintf(buf, sizeof buf, "| %s | %s | %llu | %.0f | %.4f [%.4f, %.4f] | %.3f | %s | %s |\n",
                  r.entries[i].name.c_str(), r.entries[i].variant.c_str(),
                  static_cast<unsigned long long>(r.entries[i].seed), s.entry_races[i], s.entry_rate[i].point,
                  s.entry_rate[i].lo, s.entry_rate[i].hi, per_race(s.entry_blocks[i], s.entry_races[i]),
                  hl_description(r.entries[i]).c_str(), s.counted[i] ? "yes" : "no");
    md << buf;
  }
}

// One row of the controls table: run i against each of its own controls (one cell per rule).
void control_row_md(const TournamentResult& r, int i, const std::vector<HlOverride>& rules, std::ostringstream& md) {
  const int n = static_cast<int>(r.entries.size());
  std::vector<std::string> cells(rules.size());
  double races = 0.0;
  bool any = false;
  char buf[512];
  for (int j = 0; j < n; ++j) {
    if (!is_control(r.entries[j]) || r.entries[j].policy != r.entries[i].policy || r.games[i][j] == 0) continue;
    const Interval ci = wilson_interval(r.wins[i][j], r.games[i][j]);
    std::snprintf(buf, sizeof buf, "%.3f [%.3f, %.3f]", ci.point, ci.lo, ci.hi);
    const auto at = std::find(rules.begin(), rules.end(), r.entries[j].hl) - rules.begin();
    cells[static_cast<std::size_t>(at)] = buf;
    races = r.games[i][j];
    any = true;
  }
  if (!any) return;
  std::snprintf(buf, sizeof buf, "| %s | %.0f |", r.entries[i].name.c_str(), races);
  md << buf;
  for (const std::string& c : cells) md << " " << (c.empty() ? "-" : c) << " |";
  md << "\n";
}

// What each entry's high level chose: below, on or above the middle bin, per goal axis. The
// autopilot has no high level (its goals stay on the middle bin, for the reward alone).
void goal_choices_md(const TournamentResult& r, const TournamentStatistics& s, std::ostringstream& md) {
  const auto names = goal_axis_names(r.race);
  md << "\nHigh-level goal choices: share of each entry's decisions (living aircraft) below / on / above the middle "
        "bin, per goal axis:\n\n| entry | decisions |";
  for (const char* a : names) md << " " << a << " |";
  md << "\n|---|---|---|---|---|\n";
  char buf[64];
  for (std::size_t i = 0; i < r.entries.size(); ++i) {
    if (is_autopilot(r.entries[i])) continue;
    const GoalChoiceShares g = goal_choice_shares(s.entry_choices[i]);
    std::snprintf(buf, sizeof buf, "%.0f", g.decisions);
    md << "| " << r.entries[i].name << " | " << buf << " |";
    for (int d = 0; d < race::kHlDims; ++d) {
      if (g.decisions > 0)
        std::snprintf(buf, sizeof buf, " %.3f / %.3f / %.3f |", g.share[d * 3], g.share[d * 3 + 1], g.share[d * 3 + 2]);
      else
        std::snprintf(buf, sizeof buf, " - |");
      md << buf;
    }
    md << "\n";
  }
}

// What the trained high level adds: each run against its own controls, head to head.
void controls_md(const TournamentResult& r, std::ostringstream& md) {
  const int n = static_cast<int>(r.entries.size());
  bool any_control = false;
  for (int i = 0; i < n; ++i) any_control = any_control || is_control(r.entries[i]);
  if (!any_control) return;
  // One column per rule that some entry has, in the order of the enum.
  std::vector<HlOverride> rules;
  for (HlOverride rule : hl_override_rules())
    for (int i = 0; i < n; ++i)
      if (r.entries[i].hl == rule) {
        rules.push_back(rule);
        break;
      }
  md << "\nTrained high level vs its own controls (same low level), head to head [95% Wilson CI]:\n\n| run | races |";
  for (HlOverride rule : rules) md << " vs RUN@" << hl_override_name(rule) << " |";
  md << "\n|---|---|";
  for (std::size_t k = 0; k < rules.size(); ++k) md << "---|";
  md << "\n";
  for (int i = 0; i < n; ++i)
    if (!is_control(r.entries[i])) control_row_md(r, i, rules, md);
}

}  // namespace

std::string summary_markdown(const TournamentResult& r, const TournamentStatistics& s, const TournamentOptions& o) {
  std::ostringstream md;
  md << "# Tournament\n\n" << o.races_per_pair << " races per pair (race r on track r / 2: each track from both sides), HL epsilon " << o.epsilon
     << ", " << r.races.size() << " races in all.\n\n";
  if (!r.numerics_note.empty()) md << "**Numeric modes differ**: " << r.numerics_note << "\n\n";
  variant_table_md(s, md);
  excluded_md(r, s, o, md);
  matrix_and_entries_md(r, s, md);
  controls_md(r, md);
  goal_choices_md(r, s, md);
  return md.str();
}

std::vector<std::string> write_tournament_figures(const TournamentResult& r, const TournamentStatistics& s,
                                                  const std::string& out_dir) {
  const int n = static_cast<int>(r.entries.size());
  std::vector<std::vector<double>> cols(5);
  std::vector<std::vector<std::string>> names(1);
  for (std::size_t k = 0; k < s.rows.size(); ++k) {
    cols[0].push_back(static_cast<double>(k));
    cols[1].push_back(s.rows[k].mean);
    cols[2].push_back(s.rows[k].std);
    cols[3].push_back(s.rows[k].iqm.lo);
    cols[4].push_back(s.rows[k].iqm.hi);
    names[0].push_back(s.rows[k].variant);
  }
  std::vector<double> iqm_point;
  for (const VariantRow& x : s.rows) iqm_point.push_back(x.iqm.point);
  cols.push_back(iqm_point);
  io::write_csv(out_dir + "/variants.csv", {"index", "winrate_mean", "winrate_std", "iqm_lo", "iqm_hi", "iqm"}, cols,
                {"variant"}, names);
  write_matrix_csv(out_dir + "/variant_matrix.csv", s.variant_rate);
  io::PlotSpec spec;
  spec.output = out_dir + "/tournament.png";
  spec.cols = 3;
  spec.width_px = 1800;
  spec.height_px = 550;
  spec.title = "Round-robin: " + std::to_string(r.races.size()) + " races";
  // With no variant to compare (one variant) the first two panels stay empty but keep their axes.
  std::string xr =
      "set xrange [-0.5:" + std::to_string(std::max<double>(1.0, static_cast<double>(s.rows.size())) - 0.5) + "]";
  if (s.rows.empty())
    xr += "\nunset xtics\nset label 1 'one variant: no other variant to compare with' at graph 0.5,0.5 center";
  io::PlotPanel bars{"Total winrate (mean, std over runs)", "", "winrate", {}, "set yrange [0:1]\nset style fill solid 0.6\nset boxwidth 0.6\n" + xr};
  bars.series.push_back({"variants.csv", "1:2:3:xtic(7)", "boxerrorbars lc rgb '#4477aa'", "", ""});
  io::PlotPanel iq{"IQM of pairing winrates, 95% CI", "", "winrate", {}, "set yrange [0:1]\n" + xr};
  iq.series.push_back({"variants.csv", "1:6:4:5:xtic(7)", "yerrorbars pt 7 ps 1.5 lc rgb '#cc3311'", "", ""});
  spec.panels = {bars, iq,
                 matrix_panel("Variant vs variant, mean pairing winrate (row vs column)", "variant",
                              "variant_matrix.csv", s.variants)};
  std::vector<std::string> failed;
  std::string msg;
  if (!io::render_plot(spec, out_dir + "/tournament.gp", &msg)) failed.push_back("tournament.png (" + msg + ")");

  std::vector<std::string> entry_names;
  for (const Entry& e : r.entries) entry_names.push_back(e.name);
  write_matrix_csv(out_dir + "/heatmap.csv", s.rate);
  io::PlotSpec pairings;
  pairings.output = out_dir + "/pairings.png";
  pairings.width_px = std::max(900, 300 + 75 * n);
  pairings.height_px = std::max(750, 250 + 70 * n);
  pairings.title = "Pairing winrate, every entry: " + std::to_string(r.races.size()) + " races";
  pairings.panels = {
      matrix_panel("Winrate of the row entry against the column entry", "entry", "heatmap.csv", entry_names)};
  if (!io::render_plot(pairings, out_dir + "/pairings.gp", &msg)) failed.push_back("pairings.png (" + msg + ")");
  return failed;
}

std::string write_tournament_report(const TournamentResult& r, const TournamentOptions& o,
                                    std::vector<std::string>* missing_figures) {
  fs::create_directories(o.out_dir);
  const TournamentStatistics s = tournament_statistics(r, o);
  write_races_csv(r, o.out_dir + "/races.csv");
  write_pairings_csv(r, s, o.out_dir + "/pairings.csv");
  write_summary_json(r, s, o, o.out_dir + "/summary.json");
  const std::string md = summary_markdown(r, s, o);
  io::write_file_atomic(o.out_dir + "/summary.md", md);
  const std::vector<std::string> missing = write_tournament_figures(r, s, o.out_dir);
  write_tournament_marker(o, missing, o.out_dir);  // last: the folder is whole once it is there
  if (missing_figures) *missing_figures = missing;
  return md;
}

}  // namespace f16race::eval
