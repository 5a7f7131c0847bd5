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
#include "io/csv_table.hpp"
#include "io/plot.hpp"
#include "io/yaml_config.hpp"
#include "race/race_env.hpp"
#include "train/obs_views.hpp"
#include "train/run_policy.hpp"
#include "train/train_config.hpp"

namespace f16race::eval {

namespace fs = std::filesystem;
using models::HlObs;
using models::LlObs;

namespace {

struct Game {
  int pair, blue, red;
};

}  // namespace

TournamentResult run_tournament(const TournamentOptions& o, const std::function<void(long, long)>& progress) {
  if (o.runs.empty() && !o.include_untrained) throw std::runtime_error("tournament: no entries");
  if (o.runs.empty()) throw std::runtime_error("tournament: give at least one run folder with --runs");
  TournamentResult res;
  std::vector<train::RunPolicy> pol;
  for (const std::string& r : o.runs) {
    pol.push_back(train::load_run_policy(r));
    // Races use the first run's race; every entry must have been trained for the same shapes.
    train::check_same_race_shape(pol.front(), pol.back());
    res.entries.push_back(Entry{pol.back().name, r, agents::es_variant_name(pol.back().config.hl.variant),
                                pol.back().config.seed});
  }
  race::RaceConfig rc = pol.front().config.race;
  if (o.include_untrained) {
    pol.push_back(train::untrained_policy(pol.front().config, o.seed));
    res.entries.push_back(Entry{"untrained", "", "untrained", o.seed});
  }
  const int n_entries = static_cast<int>(res.entries.size());
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
  // Aircraft rows per entry, rebuilt when a game changes.
  std::vector<torch::Tensor> rows(n_entries);
  auto rebuild_rows = [&]() {
    std::vector<std::vector<std::int64_t>> r(n_entries);
    for (std::size_t i = 0; i < owner.size(); ++i)
      if (owner[i] >= 0) r[owner[i]].push_back(static_cast<std::int64_t>(i));
    for (int id = 0; id < n_entries; ++id) rows[id] = torch::tensor(r[id], torch::kInt64);
  };
  rebuild_rows();
  std::vector<std::int64_t> bins(static_cast<std::size_t>(n) * n_agent * 3, rc.hl_bins / 2);
  std::vector<float> actions(static_cast<std::size_t>(n) * n_agent * 3, 0.0f);
  // Writes rows `idx` of `values` [M, 3] into the flat [N, 3] array `dst`.
  auto scatter = [](const torch::Tensor& idx, const torch::Tensor& values, auto* dst) {
    const auto v = values.contiguous();
    const auto* p = v.data_ptr<std::remove_pointer_t<decltype(dst)>>();
    const auto* r = idx.data_ptr<std::int64_t>();
    for (std::int64_t k = 0; k < idx.numel(); ++k) std::copy(p + 3 * k, p + 3 * k + 3, dst + 3 * r[k]);
  };
  long done_games = 0, reported = 0;
  int active = n;
  while (active > 0) {
    bool due = false;
    for (int e = 0; e < n; ++e) due = due || (env.hl_due()[e] && env_game[e] >= 0);
    if (due) {
      const HlObs obs = train::hl_obs_view(env);
      for (int id = 0; id < n_entries; ++id)
        if (rows[id].numel() > 0)
          scatter(rows[id], pol[id].hl->act(models::index_rows(obs, rows[id]), o.epsilon, gen).bins, bins.data());
      env.set_hl_actions(bins.data());
    }
    const LlObs obs = train::ll_obs_view(env);
    for (int id = 0; id < n_entries; ++id)
      if (rows[id].numel() > 0)  // greedy: the Gaussian's mean, not a sample
        scatter(rows[id], pol[id].ll->act(models::index_rows(obs, rows[id]), gen, false).mean, actions.data());
    std::vector<double> t_before(n);
    for (int e = 0; e < n; ++e) t_before[e] = env.race_time_s(e);
    env.step(actions.data());
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
    if (changed) rebuild_rows();
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

}  // namespace

void write_tournament_report(const TournamentResult& r, const TournamentOptions& o) {
  fs::create_directories(o.out_dir);
  const int n = static_cast<int>(r.entries.size());
  // races.csv
  {
    std::vector<std::vector<double>> cols(8);
    std::vector<double> durations, race_idx;
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
      names[0].push_back(r.entries[x.blue].name);
      names[1].push_back(r.entries[x.red].name);
      names[2].push_back(x.winner < 0 ? "draw" : r.entries[x.winner].name);
    }
    cols.push_back(durations);
    cols.push_back(race_idx);
    io::write_csv(o.out_dir + "/races.csv",
                  {"pair", "blue_seed", "red_seed", "track_stream_seed", "track_stream_env", "end_reason",
                   "blue_terminated", "red_terminated", "duration_s", "track_stream_race"},
                  cols, {"blue", "red", "winner"}, names);
  }
  // pairings.csv and the heatmap data (row entry's winrate against the column entry).
  std::vector<std::vector<double>> rate(n, std::vector<double>(n, std::nan("")));
  {
    std::vector<std::vector<double>> cols(4), heat(3);
    std::vector<std::vector<std::string>> names(2);
    for (int i = 0; i < n; ++i)
      for (int j = 0; j < n; ++j) {
        if (i == j || r.games[i][j] == 0) continue;
        rate[i][j] = r.wins[i][j] / r.games[i][j];
        names[0].push_back(r.entries[i].name);
        names[1].push_back(r.entries[j].name);
        cols[0].push_back(i);
        cols[1].push_back(j);
        cols[2].push_back(rate[i][j]);
        cols[3].push_back(r.games[i][j]);
      }
    io::write_csv(o.out_dir + "/pairings.csv", {"row", "column", "winrate", "races"}, cols, {"row_entry", "column_entry"},
                  names);
    for (int i = 0; i < n; ++i)
      for (int j = 0; j < n; ++j) {
        heat[0].push_back(j);
        heat[1].push_back(i);
        heat[2].push_back(i == j ? 0.5 : rate[i][j]);
      }
    io::write_csv(o.out_dir + "/heatmap.csv", {"column", "row", "winrate"}, heat);
  }
  // Per variant: mean total winrate +- std over its runs (seeds), and the IQM of its pairing
  // winrates against every entry of the other variants with a stratified-bootstrap 95 % CI.
  std::map<std::string, std::vector<int>> by_variant;
  for (int i = 0; i < n; ++i) by_variant[r.entries[i].variant].push_back(i);
  struct Row {
    std::string variant;
    int runs;
    double mean, std;
    Interval iqm;
    double races;
  };
  std::vector<Row> rows;
  for (const auto& [variant, members] : by_variant) {
    std::vector<int> opponents;
    for (int j = 0; j < n; ++j)
      if (r.entries[j].variant != variant) opponents.push_back(j);
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
    rows.push_back(Row{variant, static_cast<int>(members.size()), mean(totals), stddev(totals),
                       iqm_with_ci(scores, o.bootstrap_replicates, 0.05, o.seed), races});
  }
  {
    std::ofstream js(o.out_dir + "/summary.json");
    js << "{\n  \"races_per_pair\": " << o.races_per_pair << ",\n  \"epsilon\": " << o.epsilon
       << ",\n  \"bootstrap_replicates\": " << o.bootstrap_replicates << ",\n  \"variants\": [\n";
    for (std::size_t k = 0; k < rows.size(); ++k) {
      const Row& x = rows[k];
      js << "    {\"variant\": \"" << json_escape(x.variant) << "\", \"runs\": " << x.runs << ", \"races\": " << x.races
         << ", \"winrate_mean\": " << io::format_double(x.mean) << ", \"winrate_std\": " << io::format_double(x.std)
         << ", \"iqm\": " << io::format_double(x.iqm.point) << ", \"iqm_ci95\": [" << io::format_double(x.iqm.lo)
         << ", " << io::format_double(x.iqm.hi) << "]}" << (k + 1 < rows.size() ? "," : "") << "\n";
    }
    js << "  ]\n}\n";
    std::ofstream md(o.out_dir + "/summary.md");
    md << "# Tournament\n\n" << o.races_per_pair << " races per pair (sides swapped in half), HL epsilon " << o.epsilon
       << ", " << r.races.size() << " races in all.\n\n"
       << "| variant | runs | races | total winrate (mean +- std over runs) | IQM of pairing winrates [95% CI] |\n"
       << "|---|---|---|---|---|\n";
    char buf[256];
    for (const Row& x : rows) {
      std::snprintf(buf, sizeof buf, "| %s | %d | %.0f | %.3f +- %.3f | %.3f [%.3f, %.3f] |\n", x.variant.c_str(), x.runs,
                    x.races, x.mean, x.std, x.iqm.point, x.iqm.lo, x.iqm.hi);
      md << buf;
    }
    if (rows.empty()) md << "| (every entry has the same variant: no variant-vs-variant statistics) | | | | |\n";
    md << "\nTotal winrate: all races of a run against entries of the other variants (draws count half). IQM: "
          "25% trimmed mean over the run x opponent winrates; CI: percentile bootstrap resampling runs within "
          "each opponent (rliable's stratified bootstrap).\n\n";
    // Per entry, against every other entry: the winrate with a Wilson score 95 % interval over its
    // races (draws count half), so single runs can be compared too.
    md << "| entry | variant | seed | races | winrate vs all other entries [95% Wilson CI] |\n|---|---|---|---|---|\n";
    for (int i = 0; i < n; ++i) {
      double w = 0, g = 0;
      for (int j = 0; j < n; ++j) {
        w += r.wins[i][j];
        g += r.games[i][j];
      }
      const double p = g > 0 ? w / g : std::nan(""), z = 1.959963984540054;
      const double centre = (p + z * z / (2 * g)) / (1 + z * z / g);
      const double half = z * std::sqrt(p * (1 - p) / g + z * z / (4 * g * g)) / (1 + z * z / g);
      std::snprintf(buf, sizeof buf, "| %s | %s | %llu | %.0f | %.4f [%.4f, %.4f] |\n", r.entries[i].name.c_str(),
                    r.entries[i].variant.c_str(), static_cast<unsigned long long>(r.entries[i].seed), g, p,
                    centre - half, centre + half);
      md << buf;
    }
  }
  // Figures in the layout of the paper's Fig. 3: bars with std, IQM with CI, pairing heatmap.
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
    io::PlotSpec spec;
    spec.output = o.out_dir + "/tournament.png";
    spec.cols = 3;
    spec.width_px = 1800;
    spec.height_px = 550;
    spec.title = "Round-robin: " + std::to_string(r.races.size()) + " races";
    const std::string xr = "set xrange [-0.5:" + std::to_string(rows.size() - 0.5) + "]";
    io::PlotPanel bars{"Total winrate (mean, std over runs)", "", "winrate", {}, "set yrange [0:1]\nset style fill solid 0.6\nset boxwidth 0.6\n" + xr};
    bars.series.push_back({"variants.csv", "1:2:3:xtic(7)", "boxerrorbars lc rgb '#4477aa'", "", ""});
    io::PlotPanel iq{"IQM of pairing winrates, 95% CI", "", "winrate", {}, "set yrange [0:1]\nset xrange [-0.5:" + std::to_string(rows.size() - 0.5) + "]"};
    iq.series.push_back({"variants.csv", "1:6:4:5:xtic(7)", "yerrorbars pt 7 ps 1.5 lc rgb '#cc3311'", "", ""});
    std::string tics;
    for (int i = 0; i < n; ++i) tics += (i ? ", \"" : "\"") + r.entries[i].name + "\" " + std::to_string(i);
    io::PlotPanel hm{"Pairing winrate (row vs column)", "column entry", "row entry", {},
                     "set cbrange [0:1]\nset palette defined (0 '#b2182b', 0.5 '#f7f7f7', 1 '#2166ac')\nset autoscale fix\n"
                     "set xtics (" + tics + ") rotate by 30 right\nset ytics (" + tics + ")"};
    hm.series.push_back({"heatmap.csv", "1:2:3", "image", "", ""});
    spec.panels = {bars, iq, hm};
    std::string msg;
    io::render_plot(spec, o.out_dir + "/tournament.gp", &msg);
  }
}

}  // namespace f16race::eval
