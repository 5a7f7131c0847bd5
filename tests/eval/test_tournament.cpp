// Tournament bookkeeping on two tiny trained runs plus the untrained entry: every race counted
// once, sides swapped in half, wins and losses consistent, reports written, bad runs refused;
// the fixed-HL control entries (RUN@center, RUN@random) and who counts in the variant statistics.
#include <gtest/gtest.h>
#include <yaml-cpp/yaml.h>

#include <array>
#include <cmath>
#include <filesystem>
#include <fstream>
#include <iterator>
#include <map>
#include <set>
#include <sstream>
#include <tuple>

#include "eval/tournament.hpp"
#include "eval/tournament_report.hpp"
#include "io/yaml_config.hpp"
#include "io/input_error.hpp"
#include "race/race_env.hpp"
#include "train/obs_views.hpp"
#include "train/run_policy.hpp"
#include "train/trainer.hpp"

namespace f16race::eval {
namespace {

namespace fs = std::filesystem;

// Each test trains its own runs (ctest runs the tests of this file in parallel).
std::string trained_run(const std::string& name, int seed, int team_size = 2, const std::string& agent = "",
                        const std::string& extra = "") {
  const fs::path dir = fs::temp_directory_path() / ("f16race_tour_" + name);
  fs::remove_all(dir);
  YAML::Node root = YAML::Load(R"(
config_version: 1  # the tiny runs these tests were written for: version 1's defaults
race: {n_env: 2, time_limit_s: 10.0, dt_hl_s: 1.6, track: {n_waypoints: 5}}
ll: {n_steps: 8, n_minibatches: 2, n_epochs: 1, hidden: [8, 8], d_model: 8, n_heads: 2}
hl: {hidden: [8, 8], d_model: 8, n_heads: 2, n_atoms: 11, n_steps_per_update: 1}
train: {total_env_steps: 100, ll_phase_updates: 1, hl_phase_updates: 1}
)");
  io::apply_override(root, "seed=" + std::to_string(seed));
  io::apply_override(root, "race.team_size=" + std::to_string(team_size));
  if (!agent.empty()) io::apply_override(root, "hl.agent=" + agent);
  if (!extra.empty()) io::apply_override(root, extra);
  train::Trainer t(train::read_train_config(root, "test"), dir.string());
  t.run(nullptr, 2);
  return dir.string();
}

// --tracks: the same runs race on another config's tracks and time limit (and nothing else of
// it); no race outlasts its limit, and the per-cause counts of each team add up to its losses.
TEST(Tournament, TracksOfAnotherConfig) {
  TournamentOptions o;
  o.runs = {trained_run("tracks", 1)};
  o.include_untrained = false;
  o.include_autopilot = true;
  o.races_per_pair = 4;
  o.bootstrap_replicates = 200;
  const TournamentResult short_races = run_tournament(o);
  const fs::path cfg = fs::temp_directory_path() / "f16race_tour_tracks.yaml";
  {
    std::ofstream f(cfg);
    f << "race: {time_limit_s: 30.0, track: {n_waypoints: 9}}\n";
  }
  o.tracks_config = cfg.string();
  const TournamentResult long_races = run_tournament(o);
  double short_s = 0.0, long_s = 0.0;
  for (const RaceRecord& x : short_races.races) short_s = std::max(short_s, x.duration_s);
  for (const RaceRecord& x : long_races.races) {
    long_s = std::max(long_s, x.duration_s);
    int blue = 0, red = 0;
    for (int c = 0; c < race::kNumCauses; ++c) blue += x.blue_lost[c], red += x.red_lost[c];
    EXPECT_EQ(blue, x.blue_out());
    EXPECT_EQ(red, x.red_out());
  }
  EXPECT_EQ(short_races.race.track.n_waypoints, 5);
  EXPECT_EQ(long_races.race.track.n_waypoints, 9);
  EXPECT_EQ(long_races.race.time_limit_s, 30.0);
  EXPECT_EQ(long_races.race.team_size, short_races.race.team_size);  // the run's own, not the file's default
  EXPECT_LE(short_s, 10.0 + 0.1);
  EXPECT_LE(long_s, 30.0 + 0.1);
  o.tracks_config = (fs::temp_directory_path() / "f16race_tour_no_such.yaml").string();
  EXPECT_THROW(run_tournament(o), std::exception);
}

TEST(Tournament, CountsEveryRaceOnceWithSidesSwapped) {
  TournamentOptions o;
  o.runs = {trained_run("a", 1), trained_run("b", 2)};
  o.races_per_pair = 6;
  o.batch_envs = 7;  // batches straddle pairs
  o.bootstrap_replicates = 200;
  o.out_dir = (fs::temp_directory_path() / "f16race_tour_out").string();
  fs::remove_all(o.out_dir);
  const TournamentResult r = run_tournament(o);
  ASSERT_EQ(r.entries.size(), 3u);  // two runs and the untrained networks
  EXPECT_EQ(r.entries[2].name, "untrained");
  EXPECT_EQ(r.races.size(), 3u * 6u);
  for (int i = 0; i < 3; ++i)
    for (int j = 0; j < 3; ++j) {
      if (i == j) continue;
      EXPECT_EQ(r.games[i][j], 6.0);
      EXPECT_DOUBLE_EQ(r.wins[i][j] + r.wins[j][i], r.games[i][j]);
    }
  int blue_first[3] = {};
  for (const RaceRecord& x : r.races) {
    EXPECT_NE(x.blue, x.red);
    // A race lasts whole LL steps, at least one, at most the time limit's.
    const double steps = x.duration_s / r.race.dt_ll_s;
    EXPECT_NEAR(steps, std::round(steps), 1e-6);
    EXPECT_GE(std::round(steps), 1.0);
    EXPECT_LE(x.duration_s, r.race.time_limit_s + r.race.dt_ll_s + 1e-9);
    blue_first[x.pair] += x.blue < x.red;
  }
  for (int p : blue_first) EXPECT_EQ(p, 3);
  write_tournament_report(r, o);
  for (const char* f : {"races.csv", "pairings.csv", "summary.json", "summary.md", "tournament.gp"})
    EXPECT_TRUE(fs::exists(fs::path(o.out_dir) / f)) << f;
  {
    std::ifstream md(o.out_dir + "/summary.md");
    const std::string text((std::istreambuf_iterator<char>(md)), {});
    EXPECT_NE(text.find("| untrained | untrained | 1 | 12 |"), std::string::npos) << text;  // 6 races x 2 opponents
  }
  // Both runs are es_d3 and the untrained entry is only listed by default: no variant has an
  // opponent of another variant. Counting the untrained entry makes two variants.
  EXPECT_EQ(YAML::LoadFile(o.out_dir + "/summary.json")["variants"].size(), 0u);
  o.untrained_in_statistics = true;
  write_tournament_report(r, o);
  const YAML::Node js = YAML::LoadFile(o.out_dir + "/summary.json");
  ASSERT_EQ(js["variants"].size(), 2u);  // es_d3 (2 runs) and untrained
  for (const auto& v : js["variants"]) {
    const double lo = v["iqm_ci95"][0].as<double>(), hi = v["iqm_ci95"][1].as<double>();
    EXPECT_LE(lo, v["iqm"].as<double>() + 1e-12);
    EXPECT_GE(hi, v["iqm"].as<double>() - 1e-12);
  }
}

// Common random numbers: race r of a pairing is flown on track r / 2 from its own stream, so it is
// the same race whichever env slot it lands in and whichever other entries the tournament has
// (before, a race's track followed the order in which the batch's envs came free).
TEST(Tournament, EachRaceIsTheSameWhateverItsEnvSlotAndTheOtherEntries) {
  TournamentOptions o;
  o.runs = {trained_run("crn_a", 1), trained_run("crn_b", 2)};
  o.races_per_pair = 8;
  o.batch_envs = 7;
  const TournamentResult wide = run_tournament(o);  // a, b, untrained: pair 0 is a vs b
  o.include_untrained = false;
  o.batch_envs = 3;
  const TournamentResult narrow = run_tournament(o);  // a vs b alone, in other env slots
  std::vector<RaceRecord> w, n;
  for (const RaceRecord& x : wide.races)
    if (x.pair == 0) w.push_back(x);
  for (const RaceRecord& x : narrow.races) n.push_back(x);
  ASSERT_EQ(w.size(), 8u);
  ASSERT_EQ(n.size(), 8u);
  int other_slot = 0;
  std::set<double> durations;
  for (std::size_t k = 0; k < w.size(); ++k) {
    EXPECT_EQ(w[k].race, static_cast<int>(k));
    EXPECT_EQ(n[k].race, static_cast<int>(k));
    EXPECT_EQ(w[k].track, static_cast<int>(k) / 2);
    EXPECT_EQ(w[k].blue, n[k].blue);
    EXPECT_EQ(w[k].blue, k % 2 == 0 ? 0 : 1) << "even races: the lower entry is blue";
    EXPECT_EQ(w[k].winner, n[k].winner) << "race " << k;
    EXPECT_EQ(w[k].end_reason, n[k].end_reason) << "race " << k;
    EXPECT_DOUBLE_EQ(w[k].duration_s, n[k].duration_s) << "race " << k;
    EXPECT_EQ(w[k].blue_lost, n[k].blue_lost) << "race " << k;
    EXPECT_EQ(w[k].red_lost, n[k].red_lost) << "race " << k;
    other_slot += w[k].env != n[k].env;
    durations.insert(w[k].duration_s);
  }
  EXPECT_GT(other_slot, 0) << "the test needs races that ran in other env slots";
  EXPECT_GT(durations.size(), 1u) << "the races should differ from each other";
}

// An ensemble entry RUN+RUN: the first run's low level, the greedy bins of the mean of the
// critics' action values, each on its own normalised observations; runs over another low level
// are refused.
TEST(TournamentEnsemble, GreedyOnTheMeanOfTheCriticsOverOneLowLevel) {
  const std::string a = trained_run("ens_a", 1);
  const fs::path b = fs::temp_directory_path() / "f16race_tour_ens_b";
  fs::remove_all(b);
  fs::copy(a, b, fs::copy_options::recursive);
  const std::string hl_b = b.string() + "/checkpoint/" + train::latest_checkpoint_name(b.string()) + "/hl.pt";
  {
    // Another high level over the same low level: b's critic perturbed and saved back.
    train::RunPolicy pb = train::load_run_policy(b.string());
    torch::NoGradGuard no_grad;
    torch::manual_seed(11);
    for (auto& w : pb.hl->critic()->parameters()) w.add_(0.5 * torch::randn_like(w));
    pb.hl->save(hl_b);
  }
  train::RunPolicy pa = train::load_run_policy(a), pb = train::load_run_policy(b.string());
  train::RunPolicy ens = train::load_policy_spec(a + "+" + b.string());
  EXPECT_EQ(ens.name, "f16race_tour_ens_a+f16race_tour_ens_b");
  ASSERT_EQ(ens.hl_members.size(), 1u);

  race::RaceConfig rc = pa.config.race;
  rc.n_env = 3;
  race::RaceEnv env(rc);
  const models::HlObs obs = train::hl_obs_view(env);
  const int n = env.n_aircraft();
  const torch::Tensor rows = torch::arange(n, torch::kInt64);
  at::Generator gen = models::make_generator(1);
  std::vector<std::int64_t> bins_ens(static_cast<std::size_t>(n) * 3, -1), bins_a(bins_ens), bins_b(bins_ens);
  train::policy_hl_bins(ens, obs, rows, 0.0, gen, bins_ens.data());
  train::policy_hl_bins(pa, obs, rows, 0.0, gen, bins_a.data());
  train::policy_hl_bins(pb, obs, rows, 0.0, gen, bins_b.data());
  const torch::Tensor q = 0.5 * (pa.hl->q_values(obs) + pb.hl->q_values(obs));  // decoupled: [n, 3, bins]
  const torch::Tensor expect = q.argmax(2).contiguous();
  const std::int64_t* e = expect.data_ptr<std::int64_t>();
  for (int k = 0; k < n * 3; ++k) EXPECT_EQ(bins_ens[k], e[k]) << k;
  EXPECT_NE(bins_a, bins_b) << "the test needs two critics that choose differently";

  // A run over another low level is refused, naming its ll.pt.
  const std::string c = trained_run("ens_c", 2);
  try {
    train::load_policy_spec(a + "+" + c);
    ADD_FAILURE() << "expected a refusal";
  } catch (const io::InputError& err) {
    EXPECT_NE(std::string(err.what()).find("ll.pt: another low level"), std::string::npos) << err.what();
  }
  EXPECT_THROW(train::load_policy_spec(a + "+"), io::InputError);
}

TEST(TournamentControls, CenterRuleIsTheMiddleBinEverywhere) {
  for (int hl_bins : {1, 5, 7, 63}) {
    RandomStream rng = control_stream(3, 0);
    const std::uint64_t before = rng.state();
    std::vector<std::int64_t> bins(4 * 3, -1);
    fixed_hl_bins(HlOverride::center, hl_bins, 4, rng, bins.data());
    for (std::int64_t b : bins) EXPECT_EQ(b, hl_bins / 2) << hl_bins;
    EXPECT_EQ(rng.state(), before);  // no draws
  }
  RandomStream rng(1, 2);
  std::int64_t b[3];
  EXPECT_THROW(fixed_hl_bins(HlOverride::none, 7, 1, rng, b), std::invalid_argument);
}

TEST(TournamentControls, OneAxisRulesFixThatAxisOnly) {
  const HlOverride rules[] = {HlOverride::center_x, HlOverride::center_y, HlOverride::center_z};
  for (int axis = 0; axis < 3; ++axis) {
    RandomStream rng = control_stream(3, 0);
    const std::uint64_t before = rng.state();
    std::vector<std::int64_t> bins(5 * 3);
    for (std::size_t k = 0; k < bins.size(); ++k) bins[k] = static_cast<std::int64_t>(k % 7 == 3 ? 0 : k % 7);
    const std::vector<std::int64_t> policy = bins;
    fixed_hl_bins(rules[axis], 7, 5, rng, bins.data());
    for (std::size_t k = 0; k < bins.size(); ++k)
      EXPECT_EQ(bins[k], static_cast<int>(k % 3) == axis ? 3 : policy[k]) << "axis " << axis << ", k " << k;
    EXPECT_EQ(rng.state(), before);  // no draws
    EXPECT_TRUE(hl_override_uses_policy(rules[axis]));
  }
  EXPECT_TRUE(hl_override_uses_policy(HlOverride::none));
  EXPECT_FALSE(hl_override_uses_policy(HlOverride::center));
  EXPECT_FALSE(hl_override_uses_policy(HlOverride::random));
}

TEST(TournamentControls, RandomRuleIsUniformAndDeterministic) {
  // 20 000 aircraft x 3 axes over 7 bins: chi-square with 6 degrees of freedom below its 0.999
  // quantile (22.46), every bin drawn, every axis and aircraft position alike.
  const int n_aircraft = 20000, hl_bins = 7;
  std::vector<std::int64_t> bins(static_cast<std::size_t>(n_aircraft) * 3);
  RandomStream rng = control_stream(5, 1);
  fixed_hl_bins(HlOverride::random, hl_bins, n_aircraft, rng, bins.data());
  std::vector<std::vector<double>> count(3, std::vector<double>(hl_bins, 0.0));
  for (std::size_t k = 0; k < bins.size(); ++k) {
    ASSERT_GE(bins[k], 0);
    ASSERT_LT(bins[k], hl_bins);
    count[k % 3][bins[k]] += 1;
  }
  for (int axis = 0; axis < 3; ++axis) {
    const double expected = static_cast<double>(n_aircraft) / hl_bins;
    double chi2 = 0.0;
    for (double c : count[axis]) chi2 += (c - expected) * (c - expected) / expected;
    EXPECT_LT(chi2, 22.46) << "axis " << axis;
  }
  // Same seed and env: the same bins, also when drawn a team (2 aircraft) at a time.
  std::vector<std::int64_t> again(bins.size());
  RandomStream rng2 = control_stream(5, 1);
  for (int a = 0; a < n_aircraft; a += 2) fixed_hl_bins(HlOverride::random, hl_bins, 2, rng2, again.data() + 3 * a);
  EXPECT_EQ(again, bins);
  // Another env or another seed: other bins.
  for (auto other : {control_stream(5, 2), control_stream(6, 1)}) {
    std::vector<std::int64_t> x(bins.size());
    fixed_hl_bins(HlOverride::random, hl_bins, n_aircraft, other, x.data());
    EXPECT_NE(x, bins);
  }
}

// Every race counts each team's goal choices: the same decisions on every axis, at least one per
// aircraft (the first decision, all alive) and at most one per aircraft and HL interval; @center
// on the middle bin alone, @random near 3/7, 1/7, 3/7 of 7 bins; summary.json's shares add to 1.
TEST(TournamentControls, GoalChoicesCountEveryDecisionOfTheLivingAircraft) {
  TournamentOptions o;
  o.runs = {trained_run("choices", 1, 2, "es_d2")};
  o.controls = true;
  o.include_untrained = false;
  o.races_per_pair = 24;
  o.batch_envs = 16;
  o.bootstrap_replicates = 200;
  o.out_dir = (fs::temp_directory_path() / "f16race_tour_choices_out").string();
  fs::remove_all(o.out_dir);
  const TournamentResult r = run_tournament(o);
  ASSERT_EQ(r.entries.size(), 3u);  // the run, @center, @random
  const int ts = r.race.team_size, mid = r.race.hl_center_bin();
  ASSERT_EQ(mid, 3);
  std::array<double, kChoiceFields> random_sum{};
  for (const RaceRecord& x : r.races) {
    const int max_decisions = ts * (static_cast<int>(std::ceil(x.duration_s / r.race.dt_hl_s)) + 1);
    for (const auto& [entry, c] : {std::make_pair(x.blue, x.blue_choices), std::make_pair(x.red, x.red_choices)}) {
      const int decisions = c[0] + c[1] + c[2];
      EXPECT_GE(decisions, ts);
      EXPECT_LE(decisions, max_decisions) << x.duration_s;
      for (int d = 1; d < race::kHlDims; ++d) EXPECT_EQ(c[d * 3] + c[d * 3 + 1] + c[d * 3 + 2], decisions);
      if (r.entries[entry].hl == HlOverride::center) {
        for (int d = 0; d < race::kHlDims; ++d) EXPECT_EQ(c[d * 3 + 1], decisions);
      }
      // Against the run only: race r of every pairing draws @random's bins from one stream (common
      // random numbers), so its pairing with @center repeats the same draws.
      if (r.entries[entry].hl == HlOverride::random && (x.blue == 0 || x.red == 0))
        for (int k = 0; k < kChoiceFields; ++k) random_sum[k] += c[k];
    }
  }
  const double n = random_sum[0] + random_sum[1] + random_sum[2];
  ASSERT_GT(n, 100.0);
  for (int d = 0; d < race::kHlDims; ++d) {
    // Binomial sd of a share p over n draws: within 4 of them.
    for (const auto& [k, p] : {std::make_pair(0, 3.0 / 7), std::make_pair(1, 1.0 / 7), std::make_pair(2, 3.0 / 7)})
      EXPECT_NEAR(random_sum[d * 3 + k] / n, p, 4.0 * std::sqrt(p * (1 - p) / n)) << "axis " << d << " share " << k;
  }
  write_tournament_report(r, o);
  const YAML::Node js = YAML::LoadFile(o.out_dir + "/summary.json");
  for (std::size_t i = 0; i < 3; ++i) {
    const YAML::Node g = js["entries"][i]["goal_choices"];
    EXPECT_GT(g["decisions"].as<double>(), 0.0);
    for (const char* axis : {"along", "right", "up"}) {
      ASSERT_EQ(g[axis].size(), 3u) << axis;
      EXPECT_NEAR(g[axis][0].as<double>() + g[axis][1].as<double>() + g[axis][2].as<double>(), 1.0, 1e-12);
    }
  }
  EXPECT_EQ(js["entries"][1]["goal_choices"]["up"][1].as<double>(), 1.0);  // @center
  std::ifstream md(o.out_dir + "/summary.md");
  const std::string text((std::istreambuf_iterator<char>(md)), {});
  EXPECT_NE(text.find("| f16race_tour_choices@center | "), std::string::npos);
  EXPECT_NE(text.find("| 0.000 / 1.000 / 0.000 | 0.000 / 1.000 / 0.000 | 0.000 / 1.000 / 0.000 |"), std::string::npos)
      << text;
}

TEST(TournamentControls, EntrySpecs) {
  EXPECT_EQ(parse_entry_spec("runs/a@center"), std::make_pair(std::string("runs/a"), HlOverride::center));
  EXPECT_EQ(parse_entry_spec("runs/a@random"), std::make_pair(std::string("runs/a"), HlOverride::random));
  EXPECT_EQ(parse_entry_spec("runs/a"), std::make_pair(std::string("runs/a"), HlOverride::none));
  EXPECT_EQ(parse_entry_spec("runs/a@center_x"), std::make_pair(std::string("runs/a"), HlOverride::center_x));
  EXPECT_EQ(parse_entry_spec("runs/a@center_y"), std::make_pair(std::string("runs/a"), HlOverride::center_y));
  EXPECT_EQ(parse_entry_spec("runs/a@center_z"), std::make_pair(std::string("runs/a"), HlOverride::center_z));
  // A typo of a rule is named as one; a real folder with '@' in its name stays a folder.
  try {
    parse_entry_spec("runs/a@centre");
    FAIL() << "an unknown rule was taken for a folder";
  } catch (const std::runtime_error& e) {
    EXPECT_NE(std::string(e.what()).find("unknown high-level rule '@centre'; use RUN, RUN@center, RUN@random or "
                                         "RUN@center_x / _y / _z"),
              std::string::npos)
        << e.what();
  }
  const std::string odd = (fs::temp_directory_path() / "f16race_tour_odd@name").string();
  fs::create_directories(odd);
  EXPECT_EQ(parse_entry_spec(odd), std::make_pair(odd, HlOverride::none));
  EXPECT_EQ(parse_entry_spec("@center"), std::make_pair(std::string("@center"), HlOverride::none));
  EXPECT_STREQ(hl_override_name(HlOverride::none), "policy");
}

TEST(TournamentControls, ListedButKeptOutOfVariantStatistics) {
  TournamentOptions o;
  o.runs = {trained_run("ctl_a", 1, 2, "es_d3"), trained_run("ctl_b", 2, 2, "es_d1")};
  o.controls = true;
  o.races_per_pair = 2;
  o.batch_envs = 16;
  o.bootstrap_replicates = 200;
  o.out_dir = (fs::temp_directory_path() / "f16race_tour_ctl_out").string();
  fs::remove_all(o.out_dir);
  const TournamentResult r = run_tournament(o);
  // The runs, the untrained networks, then each run's two controls on its own policy.
  const std::vector<std::string> names = {"f16race_tour_ctl_a",        "f16race_tour_ctl_b",        "untrained",
                                          "f16race_tour_ctl_a@center", "f16race_tour_ctl_a@random", "f16race_tour_ctl_b@center",
                                          "f16race_tour_ctl_b@random"};
  ASSERT_EQ(r.entries.size(), names.size());
  for (std::size_t i = 0; i < names.size(); ++i) EXPECT_EQ(r.entries[i].name, names[i]);
  const HlOverride rules[] = {HlOverride::none,   HlOverride::none,   HlOverride::none,  HlOverride::center,
                              HlOverride::random, HlOverride::center, HlOverride::random};
  const int policy[] = {0, 1, 2, 0, 0, 1, 1};
  const bool counted[] = {true, true, false, false, false, false, false};
  for (std::size_t i = 0; i < names.size(); ++i) {
    EXPECT_EQ(r.entries[i].hl, rules[i]) << i;
    EXPECT_EQ(r.entries[i].policy, policy[i]) << i;
    EXPECT_EQ(in_variant_statistics(r.entries[i], o), counted[i]) << i;
  }
  EXPECT_EQ(r.entries[3].variant, "es_d3");  // a control keeps its run's variant and seed
  EXPECT_EQ(r.entries[6].variant, "es_d1");
  EXPECT_EQ(r.entries[6].seed, 2u);
  EXPECT_EQ(r.races.size(), 21u * 2u);  // 7 entries: 21 pairs
  for (int i = 0; i < 7; ++i)
    for (int j = 0; j < 7; ++j)
      if (i != j) {
        EXPECT_EQ(r.games[i][j], 2.0);
      }

  write_tournament_report(r, o);
  for (const char* f : {"summary.json", "summary.md", "tournament.gp", "pairings.gp", "variant_matrix.csv"})
    EXPECT_TRUE(fs::exists(fs::path(o.out_dir) / f)) << f;
  {
    const YAML::Node js = YAML::LoadFile(o.out_dir + "/summary.json");
    EXPECT_FALSE(js["untrained_in_statistics"].as<bool>());
    EXPECT_EQ(js["excluded_from_variant_statistics"].size(), 5u);
    // Entries: every one listed, 6 opponents x 2 races each, winrate inside its Wilson interval.
    ASSERT_EQ(js["entries"].size(), 7u);
    double win_sum = 0.0;
    for (std::size_t i = 0; i < 7; ++i) {
      const YAML::Node e = js["entries"][i];
      EXPECT_EQ(e["name"].as<std::string>(), names[i]);
      EXPECT_EQ(e["hl"].as<std::string>(), hl_override_name(rules[i]));
      EXPECT_EQ(e["in_variant_statistics"].as<bool>(), counted[i]);
      EXPECT_EQ(e["races"].as<double>(), 12.0);
      const double w = e["winrate"].as<double>(), lo = e["wilson95"][0].as<double>(), hi = e["wilson95"][1].as<double>();
      EXPECT_LE(lo, w);
      EXPECT_GE(hi, w);
      EXPECT_LT(lo, hi);
      win_sum += w * 12.0;
    }
    EXPECT_NEAR(win_sum, 42.0, 1e-9);  // every race won by someone, draws half each
    // Pairings: every ordered pair that played, row's winrate + column's = 1.
    ASSERT_EQ(js["pairings"].size(), 42u);
    std::map<std::pair<std::string, std::string>, double> rate;
    for (const auto& p : js["pairings"]) {
      EXPECT_EQ(p["races"].as<double>(), 2.0);
      rate[{p["row"].as<std::string>(), p["col"].as<std::string>()}] = p["winrate"].as<double>();
    }
    EXPECT_EQ(rate.size(), 42u);
    for (const auto& [k, v] : rate) EXPECT_DOUBLE_EQ(v + rate.at({k.second, k.first}), 1.0);
    // Variants: only the two runs' games against each other (2 races), nothing with a control
    // or the untrained networks.
    ASSERT_EQ(js["variants"].size(), 2u);
    for (const auto& v : js["variants"]) {
      EXPECT_EQ(v["runs"].as<int>(), 1);
      EXPECT_EQ(v["races"].as<double>(), 2.0);
    }
    EXPECT_EQ(js["variants"][0]["variant"].as<std::string>(), "es_d1");
    const double ab = rate.at({names[1], names[0]});
    EXPECT_DOUBLE_EQ(js["variants"][0]["winrate_mean"].as<double>(), ab);
    // Variant vs variant: es_d1 vs es_d3 is the one pairing; one run per variant leaves the
    // diagonal without pairings (null).
    const YAML::Node vv = js["variant_vs_variant"];
    ASSERT_EQ(vv["variants"].size(), 2u);
    EXPECT_DOUBLE_EQ(vv["winrate"][0][1].as<double>(), ab);
    EXPECT_DOUBLE_EQ(vv["winrate"][1][0].as<double>(), 1.0 - ab);
    EXPECT_TRUE(vv["winrate"][0][0].IsNull());
    EXPECT_EQ(vv["pairings"][0][1].as<int>(), 1);
  }
  {
    std::ifstream md(o.out_dir + "/summary.md");
    const std::string text((std::istreambuf_iterator<char>(md)), {});
    EXPECT_NE(text.find("Excluded from the variant statistics"), std::string::npos) << text;
    EXPECT_NE(text.find("| f16race_tour_ctl_b@random | es_d1 | 2 | 12 |"), std::string::npos) << text;
    EXPECT_NE(text.find("| untrained | untrained | 1 | 12 |"), std::string::npos) << text;
  }
  // --with-untrained: the untrained entry becomes a variant of its own; controls stay out.
  o.untrained_in_statistics = true;
  write_tournament_report(r, o);
  {
    const YAML::Node js = YAML::LoadFile(o.out_dir + "/summary.json");
    EXPECT_EQ(js["excluded_from_variant_statistics"].size(), 4u);
    EXPECT_TRUE(js["entries"][2]["in_variant_statistics"].as<bool>());
    ASSERT_EQ(js["variants"].size(), 3u);  // es_d1, es_d3, untrained
    for (const auto& v : js["variants"]) EXPECT_EQ(v["races"].as<double>(), 4.0) << v["variant"].as<std::string>();
    EXPECT_EQ(js["variant_vs_variant"]["variants"].size(), 3u);
  }
  // Same options, same races: the @random streams are seeded.
  const TournamentResult again = run_tournament(o);
  ASSERT_EQ(again.races.size(), r.races.size());
  for (std::size_t k = 0; k < r.races.size(); ++k) {
    EXPECT_EQ(again.races[k].winner, r.races[k].winner) << k;
    EXPECT_EQ(again.races[k].duration_s, r.races[k].duration_s) << k;
  }
}

// --controls-own-run: a control races its own run alone; the runs, the untrained entry and the
// autopilot still race each other, and every race kept is the full tournament's race (same track,
// start and @random streams: the same winner and duration).
TEST(TournamentControls, ControlsOwnRunRaceTheirRunAlone) {
  TournamentOptions o;
  o.runs = {trained_run("own_a", 1, 2, "es_d2"), trained_run("own_b", 2, 2, "es_d3")};
  o.controls = true;
  o.include_autopilot = true;
  o.races_per_pair = 4;
  o.batch_envs = 16;
  const TournamentResult full = run_tournament(o);
  o.controls_own_run = true;
  const TournamentResult own = run_tournament(o);
  // Entries: a, b, untrained, autopilot, a@center, a@random, b@center, b@random.
  ASSERT_EQ(own.entries.size(), 8u);
  std::set<std::pair<int, int>> pairs;
  for (const RaceRecord& x : own.races) pairs.insert({std::min(x.blue, x.red), std::max(x.blue, x.red)});
  const std::set<std::pair<int, int>> expected = {{0, 1}, {0, 2}, {0, 3}, {1, 2}, {1, 3}, {2, 3},
                                                  {0, 4}, {0, 5}, {1, 6}, {1, 7}};
  EXPECT_EQ(pairs, expected);
  EXPECT_EQ(own.races.size(), expected.size() * 4u);
  std::map<std::tuple<int, int, int>, const RaceRecord*> by_game;  // (blue, red, race)
  for (const RaceRecord& x : full.races) by_game[{x.blue, x.red, x.race}] = &x;
  for (const RaceRecord& x : own.races) {
    const RaceRecord& f = *by_game.at({x.blue, x.red, x.race});
    EXPECT_EQ(x.track, f.track);
    EXPECT_EQ(x.winner, f.winner);
    EXPECT_EQ(x.duration_s, f.duration_s);
    EXPECT_EQ(x.blue_choices, f.blue_choices);
  }
  o.controls = false;
  EXPECT_THROW(run_tournament(o), io::InputError);  // nothing for the option to pair
}

// --axis-controls: each run's own high level with one goal axis on the middle bin, listed after
// the untrained entry, kept out of the variant statistics and in the head-to-head table.
TEST(TournamentControls, AxisControlsAreListedAndKeptOutOfStatistics) {
  TournamentOptions o;
  o.runs = {trained_run("axis_a", 1, 2, "es_d2")};
  o.axis_controls = true;
  o.races_per_pair = 2;
  o.batch_envs = 16;
  o.bootstrap_replicates = 100;
  o.out_dir = (fs::temp_directory_path() / "f16race_tour_axis_out").string();
  fs::remove_all(o.out_dir);
  const TournamentResult r = run_tournament(o);
  const std::vector<std::string> names = {"f16race_tour_axis_a", "untrained", "f16race_tour_axis_a@center_x",
                                          "f16race_tour_axis_a@center_y", "f16race_tour_axis_a@center_z"};
  const HlOverride rules[] = {HlOverride::none, HlOverride::none, HlOverride::center_x, HlOverride::center_y,
                              HlOverride::center_z};
  ASSERT_EQ(r.entries.size(), names.size());
  for (std::size_t i = 0; i < names.size(); ++i) {
    EXPECT_EQ(r.entries[i].name, names[i]);
    EXPECT_EQ(r.entries[i].hl, rules[i]) << i;
    EXPECT_EQ(r.entries[i].policy, i == 1 ? 1 : 0) << i;
    EXPECT_EQ(in_variant_statistics(r.entries[i], o), i == 0) << i;
  }
  EXPECT_EQ(r.races.size(), 10u * 2u);
  write_tournament_report(r, o);
  std::ifstream md(o.out_dir + "/summary.md");
  const std::string text((std::istreambuf_iterator<char>(md)), {});
  EXPECT_NE(text.find("| run | races | vs RUN@center_x | vs RUN@center_y | vs RUN@center_z |\n|---|---|---|---|---|"),
            std::string::npos)
      << text;
  EXPECT_NE(text.find("| f16race_tour_axis_a@center_y | es_d2 | 1 | 8 |"), std::string::npos) << text;
}

// The classic-control baseline entry: AeroBench's waypoint autopilot, no networks. Listed after
// "untrained", out of the variant statistics, and a real pilot: it outflies the untrained networks.
TEST(TournamentAutopilot, ListedOutOfStatisticsAndOutfliesTheUntrainedNetworks) {
  TournamentOptions o;
  o.runs = {trained_run("ap_a", 1, 2, "es_d3")};
  o.include_autopilot = true;
  o.races_per_pair = 16;
  o.batch_envs = 16;
  o.bootstrap_replicates = 200;
  o.out_dir = (fs::temp_directory_path() / "f16race_tour_ap_out").string();
  fs::remove_all(o.out_dir);
  const TournamentResult r = run_tournament(o);
  ASSERT_EQ(r.entries.size(), 3u);
  EXPECT_EQ(r.entries[2].name, "autopilot");
  EXPECT_TRUE(is_autopilot(r.entries[2]));
  EXPECT_FALSE(is_autopilot(r.entries[1]));
  EXPECT_FALSE(in_variant_statistics(r.entries[2], o));
  EXPECT_TRUE(in_variant_statistics(r.entries[0], o));
  EXPECT_EQ(r.games[2][1], 16.0);
  EXPECT_EQ(r.games[2][0], 16.0);
  std::printf("autopilot vs untrained: %.1f of 16 races won\n", r.wins[2][1]);
  EXPECT_GE(r.wins[2][1], 12.0);
  write_tournament_report(r, o);
  std::ifstream md(o.out_dir + "/summary.md");
  const std::string text((std::istreambuf_iterator<char>(md)), {});
  EXPECT_NE(text.find("| autopilot | autopilot |"), std::string::npos);
  EXPECT_NE(text.find("none: AeroBench's waypoint autopilot"), std::string::npos);
  // The summary states the set point it flew, not the start speed.
  std::ostringstream set_point;
  set_point << "start lane at " << r.race.autopilot_airspeed() << " ft/s (its set point";
  EXPECT_NE(text.find(set_point.str()), std::string::npos) << text;
}

// --autopilot-on-line: the autopilot entry flies its lanes shifted onto each race's racing line,
// so the same races end otherwise; without a line to fly, or without the entry, it is refused.
TEST(TournamentAutopilot, OnTheRacingLineFliesOtherRaces) {
  TournamentOptions o;
  o.runs = {trained_run("ap_line", 1, 2)};
  o.include_untrained = false;
  o.include_autopilot = true;
  o.controls = true;
  o.races_per_pair = 8;
  o.batch_envs = 8;
  o.bootstrap_replicates = 100;
  o.goal_line_frac = 0.25;
  auto races = [&](bool on_line, const std::string& name) {
    o.autopilot_on_line = on_line;
    o.out_dir = (fs::temp_directory_path() / ("f16race_tour_" + name)).string();
    fs::remove_all(o.out_dir);
    write_tournament_report(run_tournament(o), o);
    std::ifstream csv(o.out_dir + "/races.csv");
    return std::string((std::istreambuf_iterator<char>(csv)), {});
  };
  const std::string lanes = races(false, "ap_lanes_out"), line = races(true, "ap_line_out");
  EXPECT_FALSE(lanes.empty());
  EXPECT_NE(lanes, line);
  std::ifstream done(o.out_dir + "/done.txt");
  const std::string marker((std::istreambuf_iterator<char>(done)), {});
  EXPECT_NE(marker.find(" autopilot_on_line=yes"), std::string::npos) << marker;
  auto refusal = [&](TournamentOptions bad) {
    try {
      run_tournament(bad);
    } catch (const io::InputError& e) {
      return std::string(e.what());
    }
    return std::string("(accepted)");
  };
  TournamentOptions center = o;
  center.goal_line_frac = 0.0;
  EXPECT_NE(refusal(center).find("races on the center-line (race.goal_line_frac 0); give --set race.goal_line_frac=F"),
            std::string::npos);
  TournamentOptions no_entry = o;
  no_entry.include_autopilot = false;
  EXPECT_NE(refusal(no_entry).find("--autopilot-on-line sets the autopilot entry's lanes; add --with-autopilot"),
            std::string::npos);
}

TEST(Tournament, RefusesMissingAndMismatchedRuns) {
  TournamentOptions o;
  o.runs = {"/nonexistent/run"};
  try {
    run_tournament(o);
    FAIL();
  } catch (const std::runtime_error& e) {
    EXPECT_NE(std::string(e.what()).find("/nonexistent/run: not a training run"), std::string::npos) << e.what();
  }
  o.runs = {trained_run("c", 3, 2), trained_run("d", 4, 1)};
  try {
    run_tournament(o);
    FAIL();
  } catch (const std::runtime_error& e) {
    EXPECT_NE(std::string(e.what()).find("f16race_tour_d: trained on 1 vs 1"), std::string::npos) << e.what();
  }
  // One run given twice (also as another spelling of the same path) would be counted as two seeds.
  const std::string c = trained_run("c", 3, 2);
  o.runs = {c, c + "/."};
  try {
    run_tournament(o);
    FAIL();
  } catch (const std::runtime_error& e) {
    EXPECT_NE(std::string(e.what()).find("is given twice in --runs"), std::string::npos) << e.what();
  }
  // One run without the untrained entry or controls has nobody to race (was an internal error).
  o.runs = {c};
  o.include_untrained = false;
  try {
    run_tournament(o);
    FAIL();
  } catch (const std::runtime_error& e) {
    EXPECT_NE(std::string(e.what()).find("is the only entry and has no opponent"), std::string::npos) << e.what();
  }
  // The same bins mean other lanes in another goal frame.
  o.runs = {c, trained_run("e", 5, 2, "", "race.goal_frame=world")};
  try {
    run_tournament(o);
    FAIL();
  } catch (const std::runtime_error& e) {
    EXPECT_NE(std::string(e.what()).find("f16race_tour_e: trained with another race.goal_frame"), std::string::npos)
        << e.what();
  }
}

}  // namespace
}  // namespace f16race::eval
