// The training loop: config validation, run-folder safety, checkpoints (atomic, refused when
// corrupt or mismatched), exact resume, determinism, and the self-play pool draws.
#include <gtest/gtest.h>
#include <sys/resource.h>
#include <sys/wait.h>
#include <unistd.h>
#include <torch/serialize/input-archive.h>
#include <torch/serialize/output-archive.h>
#include <yaml-cpp/yaml.h>

#include <algorithm>
#include <array>
#include <cmath>
#include <csignal>
#include <filesystem>
#include <fstream>
#include <initializer_list>
#include <iterator>
#include <sstream>
#include <memory>
#include <string>
#include <vector>

#include "io/atomic_file.hpp"
#include "io/input_error.hpp"
#include "io/yaml_config.hpp"
#include "race/race_config.hpp"
#include "race/race_env.hpp"
#include "train/run_policy.hpp"
#include "train/trainer.hpp"
#include "support/temp_paths.hpp"

namespace f16race::train {
namespace {

namespace fs = std::filesystem;

// A tiny run of version 1's defaults (the paper's simpler run: center-line goals, the policy's
// throttle and exploration, es_d3, no HL-only tail), which the tests below switch features on from.
const char* kSmoke = R"(
config_version: 1
seed: 3
race: {n_env: 3, team_size: 2, time_limit_s: 12.0, dt_hl_s: 1.6, track: {n_waypoints: 5}}
ll: {n_steps: 8, n_minibatches: 2, n_epochs: 2, hidden: [16, 16], d_model: 8, n_heads: 2}
hl: {agent: es_d3, hidden: [16, 16], d_model: 8, n_heads: 2, n_atoms: 11, n_steps_per_update: 1}
train: {total_env_steps: 600, ll_phase_updates: 2, hl_phase_updates: 1, checkpoint_every_updates: 3}
pool: {snapshot_every_updates: 2, max_snapshots: 2}
)";

TrainConfig smoke(std::initializer_list<std::string> overrides) {
  YAML::Node root = YAML::Load(kSmoke);
  for (const std::string& o : overrides) io::apply_override(root, o);
  return read_train_config(root, "smoke.yaml");
}

TrainConfig smoke(const std::string& extra = "") { return extra.empty() ? smoke({}) : smoke({extra}); }

std::string fresh_dir(const std::string& name) { return test_support::fresh_temp_path("train_test_" + name); }

// The run `config` gives, stopped (with its checkpoint) after `stop_after` updates in a fresh
// folder named `name`, then resumed there and run to its end: the "killed and resumed" half of
// the resume tests.
std::unique_ptr<Trainer> stopped_and_resumed(const TrainConfig& config, const std::string& name,
                                             std::int64_t stop_after) {
  const std::string dir = fresh_dir(name);
  {
    Trainer t(config, dir);
    t.run(nullptr, stop_after);
  }
  auto resumed = Trainer::resume(dir);
  resumed->run();
  return resumed;
}

// The first update of smoke(tail)'s HL-only tail at hl_tail_share 0.5 (half of its 600 env steps).
std::size_t first_tail_update(const TrainSummary& run) {
  std::size_t k = 0;
  while (k < run.rows.size() && run.rows[k].env_steps < 300) ++k;
  return k;
}

bool same_or_both_nan(double x, double y) { return x == y || (std::isnan(x) && std::isnan(y)); }

// Copies the live run folder `from` to `to` as a kill would leave it. The learning-curve draw runs
// beside training (io::BackgroundCurves) and renames its temporary image while the copy walks the
// folder, so a file that is gone by the time it is copied is skipped, as `cp -r` would report it
// and go on; resume needs none of the draw's files.
void copy_live_run_folder(const fs::path& from, const fs::path& to) {
  fs::create_directories(to);
  for (const auto& e : fs::recursive_directory_iterator(from, fs::directory_options::skip_permission_denied)) {
    const fs::path target = to / fs::relative(e.path(), from);
    std::error_code ec;
    if (e.is_directory(ec)) {
      fs::create_directories(target);
    } else if (!fs::copy_file(e.path(), target, fs::copy_options::overwrite_existing, ec) &&
               ec != std::errc::no_such_file_or_directory) {
      throw fs::filesystem_error("copy_live_run_folder", e.path(), target, ec);
    }
  }
}

// Rows [0, n) of two runs' metrics agree: the same steps, LL and HL returns.
void expect_same_rows(const TrainSummary& a, const TrainSummary& b, std::size_t n) {
  for (std::size_t i = 0; i < n; ++i) {
    EXPECT_EQ(a.rows[i].env_steps, b.rows[i].env_steps) << "update " << i;
    EXPECT_TRUE(same_or_both_nan(a.rows[i].ll_return, b.rows[i].ll_return)) << "update " << i;
    EXPECT_TRUE(same_or_both_nan(a.rows[i].hl_return, b.rows[i].hl_return)) << "update " << i;
  }
}

std::string error_of(const std::string& yaml) {
  try {
    read_train_config(YAML::Load(yaml), "cfg.yaml");
  } catch (const io::ConfigError& e) {
    return e.what();
  }
  return "";
}

TEST(TrainConfig, BadKeysTypesAndRangesNameFileAndKey) {
  EXPECT_NE(error_of("ll: {n_stepz: 4}").find("cfg.yaml: unknown key 'll.n_stepz'"), std::string::npos);
  EXPECT_NE(error_of("optimizer: {}").find("unknown key 'optimizer'"), std::string::npos);
  EXPECT_NE(error_of("hl: {agent: es_d4}").find("hl.agent: 'es_d4' is not one of: es, es_d1, es_d2, es_d3"),
            std::string::npos);
  EXPECT_NE(error_of("race: {n_env: many}").find("race.n_env: expected an integer, got 'many'"), std::string::npos);
  EXPECT_NE(error_of("hl: {epsilon: 1.5}").find("hl.epsilon: value 1.5 is out of range; allowed [0, 1]"),
            std::string::npos);
  EXPECT_NE(error_of("race: {team_size: 9}").find("race.team_size"), std::string::npos);
  EXPECT_NE(error_of("hl: {v_min: 5, v_max: 1}").find("hl.v_min must be < hl.v_max"), std::string::npos);
  EXPECT_NE(error_of("race: {time_limit_s: 5, dt_hl_s: 8}").find("dt_hl_s (8) must be <= time_limit_s (5)"),
            std::string::npos);
  EXPECT_NE(error_of("hl: {d3_loss: mse}").find("hl.d3_loss: 'mse' is not one of: cross_entropy, huber_mean"),
            std::string::npos);
  EXPECT_NE(error_of("hl: {agent: es_d2, d3_loss: huber_mean}").find("hl.d3_loss huber_mean is ES+D3's loss"),
            std::string::npos);
  EXPECT_NE(error_of("hl: {agent: es_d3, d3_loss: huber_mean, component_ce_weight: 0.1}").find("es_d3, 0.1"),
            std::string::npos);
  EXPECT_EQ(error_of("hl: {agent: es_d3, d3_loss: huber_mean}"), "");
  EXPECT_NE(error_of("train: {keep_hl_decisions: 2}").find("train.keep_hl_decisions"), std::string::npos);
}

// One seed drives a training run: race.seed may only repeat it (the config.yaml of every run
// lists both, equal); a different one would be ignored, so it is refused naming both keys.
TEST(TrainConfig, RaceSeedOtherThanSeedIsRefused) {
  EXPECT_EQ(read_train_config(YAML::Load("{seed: 4, race: {seed: 4}}"), "cfg.yaml").race.seed, 4u);
  EXPECT_EQ(read_train_config(YAML::Load("{seed: 4}"), "cfg.yaml").race.seed, 4u);
  EXPECT_EQ(error_of("{seed: 4, race: {seed: 5}}"),
            "cfg.yaml: race.seed = 5 differs from seed = 4: a training run draws its races from seed; remove race.seed");
  EXPECT_NE(error_of("race: {seed: 2}").find("race.seed = 2 differs from seed = 1"), std::string::npos);
}

// train.tail_member is the trainer's own: written into the config.yaml of a tail member's folder
// and read back from there, refused in a user's config (where 0, as older runs list it, is fine).
TEST(TrainConfig, TailMemberIsReadFromRunFoldersOnly) {
  const YAML::Node member = YAML::Load("train: {hl_tail_share: 0.3, tail_member: 2}");
  EXPECT_EQ(read_train_config(member, "m/config.yaml", ConfigOrigin::kRunFolder).loop.tail_member, 2);
  EXPECT_EQ(error_of("train: {hl_tail_share: 0.3, tail_member: 2}"),
            "cfg.yaml: train.tail_member = 2 is written by train into the members of a train.hl_tail_members run, not "
            "read from a config: set train.hl_tail_members instead");
  TrainConfig c = smoke("train.hl_tail_share=0.5");
  c.loop.tail_member = 3;
  const std::string y = train_config_yaml(c);
  EXPECT_NE(y.find("tail_member: 3"), std::string::npos);
  EXPECT_EQ(train_config_yaml(read_train_config(YAML::Load(y), "m", ConfigOrigin::kRunFolder)), y);
  EXPECT_THROW(read_train_config(YAML::Load("train: {tail_member: 2}"), "m", ConfigOrigin::kRunFolder), io::ConfigError);
}

TEST(TrainConfig, ResolvedYamlReadsBackToTheSameConfig) {
  const TrainConfig a = smoke("race.dt_hl_s=8");
  const std::string y = train_config_yaml(a);
  const TrainConfig b = read_train_config(YAML::Load(y), "resolved");
  EXPECT_EQ(train_config_yaml(b), y);
  EXPECT_EQ(b.race.dt_hl_s, 8.0);
  EXPECT_EQ(b.hl.variant, agents::EsVariant::kEsD3);
  EXPECT_NE(config_hash(y), config_hash(train_config_yaml(smoke("seed=4"))));
}

TEST(Trainer, SameSeedSameWeightsDifferentSeedDifferentWeights) {
  Trainer a(smoke(), fresh_dir("det_a")), b(smoke(), fresh_dir("det_b")), c(smoke("seed=9"), fresh_dir("det_c"));
  a.run(nullptr, 5);
  b.run(nullptr, 5);
  c.run(nullptr, 5);
  EXPECT_EQ(a.ll_parameters(), b.ll_parameters());
  EXPECT_EQ(a.hl_parameters(), b.hl_parameters());
  EXPECT_NE(a.ll_parameters(), c.ll_parameters());
}

// train.ll_pilot autopilot: AeroBench's waypoint autopilot flies the goal lanes, so every update
// is an ES update, the low level's network never moves, the high level's does, and a stopped
// and resumed run ends where an uninterrupted one does.
TEST(Trainer, AutopilotLowLevelLeavesOnlyTheHighLevelToLearn) {
  const std::string extra = "train.ll_pilot=autopilot";
  Trainer a(smoke(extra), fresh_dir("ap_whole"));
  const std::vector<float> ll0 = a.ll_parameters(), hl0 = a.hl_parameters();
  const TrainSummary full = a.run();
  ASSERT_GT(full.updates, 4);
  for (const MetricsRow& r : full.rows) EXPECT_EQ(r.phase, "hl") << "update " << r.update;
  EXPECT_GT(full.hl_grad_steps, 0);
  EXPECT_EQ(a.ll_parameters(), ll0);
  EXPECT_NE(a.hl_parameters(), hl0);
  EXPECT_EQ(stopped_and_resumed(smoke(extra), "ap_split", 3)->hl_parameters(), a.hl_parameters());
  EXPECT_NE(error_of("train: {ll_pilot: fly}").find("train.ll_pilot: 'fly' is not one of: ppo, autopilot"),
            std::string::npos);
  EXPECT_NE(error_of("train: {ll_pilot: autopilot, hl_phase_updates: 0}").find("train.hl_phase_updates must be > 0"),
            std::string::npos);
}

// train.keep_hl_decisions: with only the high level learning and a new pool opponent after every
// update (hl_phase_updates 1), the decisions open at a switch are learned from instead of dropped,
// so each ES batch fills in fewer env steps; a stopped and resumed run (the open decisions are in
// the checkpoint) ends where a whole one does. Off, every switch drops them, as before.
TEST(Trainer, KeptHighLevelDecisionsFillEachBatchSooner) {
  const TrainSummary dropped = Trainer(smoke("train.ll_pilot=autopilot"), fresh_dir("keep_off")).run();
  const auto keep = [] { return smoke({"train.ll_pilot=autopilot", "train.keep_hl_decisions=true"}); };
  Trainer a(keep(), fresh_dir("keep_on"));
  const TrainSummary kept = a.run();
  ASSERT_GT(dropped.rows.size(), 2u);
  // The first batch is the same (nothing was open before it); from the second on, fewer steps.
  EXPECT_EQ(kept.rows[0].env_steps, dropped.rows[0].env_steps);
  EXPECT_LT(kept.rows[1].env_steps - kept.rows[0].env_steps, dropped.rows[1].env_steps - dropped.rows[0].env_steps);
  EXPECT_GT(kept.updates, dropped.updates);
  EXPECT_EQ(stopped_and_resumed(keep(), "keep_split", 3)->hl_parameters(), a.hl_parameters());
}

// train.ll_throttle governor: the flight changes (other samples, other weights from the same
// seed), a stopped run resumes to the same end; without the Mach governor the key is refused, and
// a frozen pilot is flown only with the throttle it learned with.
TEST(Trainer, GovernorThrottleTrainsOtherWeightsAndResumesExactly) {
  const std::string extra = "train.ll_throttle=governor";
  Trainer policy(smoke(), fresh_dir("thr_policy"));
  policy.run();
  const std::string pilot_dir = fresh_dir("thr_whole");
  Trainer a(smoke(extra), pilot_dir);
  a.run();
  EXPECT_NE(a.ll_parameters(), policy.ll_parameters());
  EXPECT_EQ(stopped_and_resumed(smoke(extra), "thr_split", 3)->ll_parameters(), a.ll_parameters());
  EXPECT_NE(error_of("race: {mach_governor: false}\ntrain: {ll_throttle: governor}")
                .find("train.ll_throttle is governor (full throttle, capped by the Mach governor) and "
                      "race.mach_governor is false"),
            std::string::npos);
  EXPECT_NE(error_of("train: {ll_throttle: full}").find("train.ll_throttle: 'full' is not one of: policy, governor"),
            std::string::npos);
  try {
    Trainer bad(smoke("train.ll_from=" + pilot_dir), fresh_dir("thr_bad"));
    ADD_FAILURE() << "a governor-throttle pilot was flown with the policy's throttle";
  } catch (const io::InputError& e) {
    EXPECT_NE(std::string(e.what()).find("another train.ll_throttle than this config's"), std::string::npos) << e.what();
  }
}

// train.ll_from: a run flies another run's trained low level, frozen, from its first update: its
// LL weights are the pilot's to the bit before and after training, only the high level learns,
// and the run resumes exactly without reading the pilot's folder again.
TEST(Trainer, LowLevelFromAnotherRunIsFlownFrozen) {
  const std::string pilot_dir = fresh_dir("llfrom_pilot");
  Trainer pilot(smoke(), pilot_dir);
  pilot.run();
  const std::vector<float> pilot_ll = pilot.ll_parameters();
  const std::string extra = "train.ll_from=" + pilot_dir;
  Trainer a(smoke(extra), fresh_dir("llfrom_whole"));
  EXPECT_EQ(a.ll_parameters(), pilot_ll);
  const std::vector<float> hl0 = a.hl_parameters();
  const TrainSummary full = a.run();
  ASSERT_GT(full.updates, 4);
  for (const MetricsRow& r : full.rows) EXPECT_EQ(r.phase, "hl") << "update " << r.update;
  EXPECT_EQ(a.ll_parameters(), pilot_ll);
  EXPECT_NE(a.hl_parameters(), hl0);
  const std::string split = fresh_dir("llfrom_split");
  {
    Trainer b(smoke(extra), split);
    b.run(nullptr, 3);
  }
  fs::rename(pilot_dir, pilot_dir + ".moved");  // a resume reads its own checkpoint only
  auto resumed = Trainer::resume(split);
  resumed->run();
  EXPECT_EQ(resumed->hl_parameters(), a.hl_parameters());
  EXPECT_EQ(resumed->ll_parameters(), pilot_ll);
  fs::rename(pilot_dir + ".moved", pilot_dir);
  // A folder without a run, and a low level of another network size, are one line each.
  // A start that fails there leaves no folder behind, unless the folder was there before.
  const std::string bad1 = fresh_dir("llfrom_bad1"), bad2 = fresh_dir("llfrom_bad2");
  try {
    Trainer bad(smoke("train.ll_from=" + fresh_dir("llfrom_nothing")), bad1);
    ADD_FAILURE() << "a folder without a run was accepted";
  } catch (const io::InputError& e) {
    EXPECT_NE(std::string(e.what()).find("train.ll_from names no trained run"), std::string::npos) << e.what();
  }
  EXPECT_FALSE(fs::exists(bad1)) << "the failed start left its run folder";
  fs::create_directories(bad2);
  try {
    TrainConfig wide = smoke(extra);
    wide.ll.net.hidden = {32, 32};
    Trainer bad(wide, bad2);
    ADD_FAILURE() << "a low level of another size was accepted";
  } catch (const io::InputError& e) {
    EXPECT_NE(std::string(e.what()).find("does not fit this config"), std::string::npos) << e.what();
  }
  EXPECT_TRUE(fs::is_directory(bad2)) << "the user's own folder was removed";
  EXPECT_NE(error_of("train: {ll_from: runs/x, ll_pilot: autopilot}").find("use one of the two"), std::string::npos);
}

// train.hl_tail_share: once the run has used (1 - share) of its env steps the low level stops
// learning (its weights are those at the switch, to the bit), every later update is an ES update,
// and a run stopped in the tail resumes exactly.
TEST(Trainer, HlTailFreezesTheLowLevelForTheLastShareOfTheSteps) {
  const std::string extra = "train.hl_tail_share=0.5";
  Trainer a(smoke(extra), fresh_dir("tail_whole"));
  const TrainSummary full = a.run();
  const std::size_t k = first_tail_update(full);  // crosses half the budget: the last that may be an LL update
  ASSERT_LT(k + 2, full.rows.size());
  EXPECT_EQ(full.rows[0].phase, "ll");
  for (std::size_t i = k + 1; i < full.rows.size(); ++i) EXPECT_EQ(full.rows[i].phase, "hl") << "update " << i;
  const std::string split = fresh_dir("tail_split");
  {
    Trainer b(smoke(extra), split);
    b.run(nullptr, static_cast<std::int64_t>(k) + 2);  // one update into the tail
    EXPECT_EQ(b.ll_parameters(), a.ll_parameters());
    EXPECT_NE(b.hl_parameters(), a.hl_parameters());
  }
  auto resumed = Trainer::resume(split);
  resumed->run();
  EXPECT_EQ(resumed->ll_parameters(), a.ll_parameters());
  EXPECT_EQ(resumed->hl_parameters(), a.hl_parameters());
  // Without the tail the same run keeps alternating to the end.
  Trainer c(smoke(), fresh_dir("tail_none"));
  const TrainSummary plain = c.run();
  ASSERT_GT(plain.rows.size(), k + 2);
  EXPECT_TRUE(std::any_of(plain.rows.begin() + static_cast<std::ptrdiff_t>(k) + 1, plain.rows.end(),
                          [](const MetricsRow& r) { return r.phase == "ll"; }));
  EXPECT_NE(error_of("train: {hl_tail_share: 1.0}").find("train.hl_tail_share: value 1 is out of range"),
            std::string::npos);
  EXPECT_NE(error_of("train: {hl_tail_share: 0.2, hl_phase_updates: 0}").find("train.hl_phase_updates must be > 0"),
            std::string::npos);
}

// pool.p_center_tail: the center-line share of the HL-only tail's races. Up to the switch the run is
// the one without it (the same low level, bit for bit, and so the same high level at the switch);
// in the tail the high level learns another way; a run stopped in the tail resumes exactly.
TEST(Trainer, CenterShareInTheTailChangesOnlyTheTail) {
  const std::string tail = "train.hl_tail_share=0.5";
  Trainer a(smoke(tail), fresh_dir("ctail_none"));
  const TrainSummary plain = a.run();
  TrainConfig centered = smoke(tail);
  centered.pool.p_center_tail = 1.0;
  Trainer b(centered, fresh_dir("ctail_whole"));
  const TrainSummary full = b.run();
  EXPECT_EQ(b.ll_parameters(), a.ll_parameters());
  EXPECT_NE(b.hl_parameters(), a.hl_parameters());
  const std::size_t k = first_tail_update(full);  // both runs agree on every row before it
  ASSERT_LT(k + 2, full.rows.size());
  ASSERT_EQ(plain.rows.size(), full.rows.size());
  expect_same_rows(full, plain, k);
  EXPECT_EQ(stopped_and_resumed(centered, "ctail_split", static_cast<std::int64_t>(k) + 2)->hl_parameters(),
            b.hl_parameters());
  EXPECT_NE(error_of("train: {hl_tail_share: 0}\npool: {p_center_tail: 0.25}").find("pool.p_center_tail = 0.25 applies to the HL-only tail"),
            std::string::npos);
}

// train.tail_member: the same run up to the HL-only tail (every metrics row, the low level bit for
// bit), another high level after it from the member's streams, and a run stopped inside its tail
// resumes to the same hl.pt as the unbroken one.
TEST(Trainer, TailMemberDrawsAnotherTailOfTheSameLowLevel) {
  const std::string tail = "train.hl_tail_share=0.5";
  Trainer a(smoke(tail), fresh_dir("member_0"));
  const TrainSummary plain = a.run();
  TrainConfig member = smoke(tail);
  member.loop.tail_member = 1;
  Trainer b(member, fresh_dir("member_1"));
  const TrainSummary other = b.run();
  EXPECT_EQ(b.ll_parameters(), a.ll_parameters());
  EXPECT_NE(b.hl_parameters(), a.hl_parameters());
  const std::size_t k = first_tail_update(other);
  ASSERT_LT(k + 2, other.rows.size());
  ASSERT_EQ(plain.rows.size(), other.rows.size());
  expect_same_rows(other, plain, k + 1);  // row k is the update that crossed into the tail
  bool differs = false;
  for (std::size_t i = k + 1; i < other.rows.size(); ++i)
    differs = differs || !same_or_both_nan(other.rows[i].es_loss, plain.rows[i].es_loss);
  EXPECT_TRUE(differs) << "the member's tail should learn from other draws";
  EXPECT_EQ(stopped_and_resumed(member, "member_split", static_cast<std::int64_t>(k) + 3)->hl_parameters(),
            b.hl_parameters());
}

// A finished run extended by a tail (its config's budget raised, train.hl_tail_share set, the
// checkpoint's hash rewritten: the way the tail experiments' arms were made) whose last checkpoint lies
// inside an LL phase finishes that phase's PPO update before the tail: a tail member's streams
// begin after it, so every member keeps the run's final low level (bit for bit).
TEST(Trainer, TailMemberStreamsBeginAfterTheLastLowLevelUpdate) {
  const std::string base = fresh_dir("extend_base");
  TrainConfig short_run = smoke();
  std::int64_t total = 0;  // a budget whose run ends one update into a two-update LL phase
  for (std::int64_t t : {300, 320, 340, 360, 380, 400}) {
    short_run.loop.total_env_steps = t;
    fs::remove_all(base);
    Trainer a(short_run, base);
    const TrainSummary sum = a.run();
    const std::size_t n = sum.rows.size();
    if (n >= 2 && sum.rows[n - 1].phase == "ll" && sum.rows[n - 2].phase == "hl") {
      total = t;
      break;
    }
  }
  ASSERT_GT(total, 0) << "no budget ends inside an LL phase";
  std::vector<std::vector<float>> ll, hl;
  for (int member : {0, 1}) {
    const std::string dir = fresh_dir("extend_" + std::to_string(member));
    fs::copy(base, dir, fs::copy_options::recursive);
    fs::remove(dir + "/.lock");
    TrainConfig longer = smoke("train.hl_tail_share=0.5");
    longer.loop.total_env_steps = 2 * total;  // the tail starts where the short run ended
    longer.loop.tail_member = member;
    const std::string yaml = train_config_yaml(longer);
    io::write_file_atomic(dir + "/config.yaml", yaml);
    const std::string meta_path = dir + "/checkpoint/" + latest_checkpoint_name(dir) + "/meta.yaml";
    std::ifstream in(meta_path);
    std::string meta((std::istreambuf_iterator<char>(in)), std::istreambuf_iterator<char>());
    const std::size_t at = meta.find("config_hash: ") + 13;
    meta = meta.substr(0, at) + std::to_string(config_hash(yaml)) + meta.substr(meta.find('\n', at));
    io::write_file_atomic(meta_path, meta);
    auto t = Trainer::resume(dir);
    t->run();
    ll.push_back(t->ll_parameters());
    hl.push_back(t->hl_parameters());
  }
  EXPECT_EQ(ll[1], ll[0]);
  EXPECT_NE(hl[1], hl[0]);
}

// A tail shorter than one update: the budget ends inside the update that enters it, no update
// starts in it, so no member is forked; training the members then says why, in one line, and
// what to change (resuming would not help: the run is finished).
TEST(Trainer, ATailInsideOneUpdateForksNoMemberAndSaysWhy) {
  TrainConfig c = smoke("train.hl_tail_share=0.005");  // 3 of 600 env steps: less than one update (24)
  c.loop.hl_tail_members = 3;
  const std::string dir = fresh_dir("members_none");
  Trainer(c, dir).run();
  EXPECT_FALSE(fs::exists(dir + "/members/1"));
  try {
    train_tail_members(dir);
    ADD_FAILURE() << "expected a refusal";
  } catch (const io::InputError& e) {
    const std::string what = e.what();
    EXPECT_NE(what.find("members/1: missing, so tail member 1 was never forked"), std::string::npos) << what;
    EXPECT_NE(what.find("a larger train.total_env_steps or train.hl_tail_share"), std::string::npos) << what;
  }
}

// train.hl_tail_members: the run forks its tail members at its tail's first update; each member,
// trained after the run, is the run of its config with tail_member m (bit for bit), the run's
// own tail is the plain run's, a run stopped after the fork resumes without forking twice, and
// the finished run's policy is the ensemble of the three.
TEST(Trainer, TailMembersAreTheRunsForksAndItsPolicyTheirEnsemble) {
  const std::string tail = "train.hl_tail_share=0.5";
  Trainer plain(smoke(tail), fresh_dir("members_plain"));
  plain.run();
  TrainConfig one = smoke(tail);
  one.loop.tail_member = 1;
  Trainer alone(one, fresh_dir("members_alone1"));
  const TrainSummary alone_sum = alone.run();
  TrainConfig ens = smoke(tail);
  ens.loop.hl_tail_members = 3;
  const std::string dir = fresh_dir("members_run");
  std::vector<float> run_hl;
  {
    Trainer t(ens, dir);
    t.run();
    run_hl = t.hl_parameters();
  }
  EXPECT_EQ(run_hl, plain.hl_parameters());
  for (int m : {1, 2}) EXPECT_TRUE(fs::is_directory(dir + "/members/" + std::to_string(m))) << m;
  try {  // members forked, not trained: the run's policy is not complete yet
    load_run_policy(dir);
    ADD_FAILURE() << "expected a refusal";
  } catch (const io::InputError& e) {
    EXPECT_NE(std::string(e.what()).find("members/1: tail member 1 is at"), std::string::npos) << e.what();
  }
  const std::vector<TrainSummary> members = train_tail_members(dir);
  ASSERT_EQ(members.size(), 2u);
  EXPECT_EQ(Trainer::resume(dir + "/members/1")->hl_parameters(), alone.hl_parameters());
  EXPECT_EQ(Trainer::resume(dir + "/members/1")->ll_parameters(), plain.ll_parameters());
  EXPECT_NE(Trainer::resume(dir + "/members/2")->hl_parameters(), alone.hl_parameters());
  const RunPolicy p = load_run_policy(dir);
  EXPECT_EQ(p.hl_members.size(), 2u);
  EXPECT_EQ(p.name, fs::path(dir).filename().string());  // the run's name, not the members'
  {  // A member's checkpoint damaged after the run ended: refused in one line naming its file,
     // never an ensemble of the members that load.
    const std::string m2 = dir + "/members/2/checkpoint/" + latest_checkpoint_name(dir + "/members/2") + "/hl.pt";
    std::ofstream(m2, std::ios::trunc) << "not a checkpoint";
    try {
      load_run_policy(dir);
      ADD_FAILURE() << "a run with a damaged member was loaded";
    } catch (const io::InputError& e) {
      const std::string what = e.what();
      EXPECT_EQ(what.rfind(m2 + ": cannot load the policy (", 0), 0u) << what;
      EXPECT_EQ(what.find('\n'), std::string::npos) << what;
    }
  }

  // Stopped two updates after the fork, resumed: the same members, forked once.
  const std::size_t k = first_tail_update(alone_sum);
  const std::string split = fresh_dir("members_split");
  {
    Trainer t(ens, split);
    t.run(nullptr, static_cast<std::int64_t>(k) + 3);
  }
  ASSERT_TRUE(fs::is_directory(split + "/members/1"));
  const auto forked_at = fs::last_write_time(split + "/members/1/config.yaml");
  Trainer::resume(split)->run();
  EXPECT_EQ(fs::last_write_time(split + "/members/1/config.yaml"), forked_at);
  train_tail_members(split);
  EXPECT_EQ(Trainer::resume(split + "/members/1")->hl_parameters(), alone.hl_parameters());
  EXPECT_EQ(Trainer::resume(split)->hl_parameters(), plain.hl_parameters());
  EXPECT_NE(error_of("train: {hl_tail_share: 0, hl_tail_members: 2}\npool: {p_center_tail: 0}").find("train.hl_tail_members = 2 is an ensemble of HL-only tails"),
            std::string::npos);
}

// The step count crosses the switch inside the low level's last update; races that end there and
// start again still belong to the bilevel part, so that update, and with it the final low level,
// is the same as without the tail's center share. Races of 6.4 s (80 LL steps) in LL updates of
// 100 steps: the third update (env steps 600-900) crosses the switch at 690, and a race that
// reaches its time limit ends at 720, inside it (on a8cd501's rule, which drew races restarted
// after 690 with the tail's share, the final low levels differ: checked).
TEST(Trainer, LastLowLevelUpdateKeepsTheBilevelMatchups) {
  TrainConfig base = smoke("train.hl_tail_share=0.655");
  base.race.time_limit_s = 6.4;
  base.ll.n_steps = 100;
  base.loop.total_env_steps = 2000;
  base.loop.ll_phase_updates = 4;
  Trainer a(base, fresh_dir("ctail_last_none"));
  const TrainSummary plain = a.run();
  ASSERT_EQ(plain.rows.at(2).phase, "ll");
  ASSERT_LT(plain.rows.at(1).env_steps, 690);
  ASSERT_GE(plain.rows.at(2).env_steps, 690);
  ASSERT_EQ(plain.rows.at(3).phase, "hl");
  TrainConfig centered = base;
  centered.pool.p_center_tail = 1.0;
  Trainer b(centered, fresh_dir("ctail_last_center"));
  b.run();
  EXPECT_EQ(b.ll_parameters(), a.ll_parameters());
  EXPECT_NE(b.hl_parameters(), a.hl_parameters());
}

TEST(Trainer, StoppedAndResumedRunEndsWithTheSameWeights) {
  const std::string whole = fresh_dir("whole"), split = fresh_dir("split");
  Trainer a(smoke(), whole);
  const TrainSummary full = a.run();
  ASSERT_GT(full.updates, 6);
  {
    Trainer b(smoke(), split);
    b.run(nullptr, 4);  // stops with a checkpoint after 4 updates: the process "dies" here
  }
  auto resumed = Trainer::resume(split);
  EXPECT_EQ(resumed->updates(), 4);
  const TrainSummary rest = resumed->run();
  EXPECT_EQ(rest.updates, full.updates);
  EXPECT_EQ(resumed->ll_parameters(), a.ll_parameters());
  EXPECT_EQ(resumed->hl_parameters(), a.hl_parameters());
  // metrics.csv has one row per update, with no duplicates from the interrupted part.
  std::ifstream m(split + "/metrics.csv");
  int lines = 0;
  for (std::string l; std::getline(m, l);) ++lines;
  EXPECT_EQ(lines, 1 + full.updates);
  // The last checkpoint's files, trainer.pt included (the wall clock lives in wall_s.txt), are
  // the unbroken run's bytes.
  const std::string name = latest_checkpoint_name(whole);
  ASSERT_EQ(latest_checkpoint_name(split), name);
  auto bytes = [&](const std::string& run, const char* file) {
    std::ifstream in(run + "/checkpoint/" + name + "/" + file, std::ios::binary);
    return std::string(std::istreambuf_iterator<char>(in), {});
  };
  for (const char* f : {"ll.pt", "hl.pt", "trainer.pt", "meta.yaml"}) {
    EXPECT_FALSE(bytes(whole, f).empty()) << f;
    EXPECT_EQ(bytes(whole, f), bytes(split, f)) << f << " differs between the resumed and the unbroken run";
  }
  EXPECT_GT(std::stod(bytes(split, "wall_s.txt")), 0.0);
}

// A run folder written before issue 51: its config.yaml lists the retired keys, and its
// checkpoints record that file's hash. At the values this build behaves as, the run resumes to
// the unbroken run's weights without its config.yaml being rewritten, and loads as a policy; with
// one of them at another value, both refuse in one line naming the key, the value and the commit.
TEST(Trainer, RunFromBeforeTheRetiredKeysResumesLoadsOrIsRefused) {
  const std::string whole = fresh_dir("retired_whole"), split = fresh_dir("retired_split");
  Trainer a(smoke(), whole);
  const TrainSummary full = a.run();
  {
    Trainer b(smoke(), split);
    b.run(nullptr, 4);
  }
  // config.yaml as the build before issue 51 wrote it (with `explore` as given), the checkpoint
  // under its hash; returns the file's text.
  auto as_older_build = [](const std::string& dir, const std::string& explore) {
    YAML::Node root = YAML::LoadFile(dir + "/config.yaml");
    root.remove("config_version");
    root["race"]["goal_origin"] = "center";
    root["race"]["observe_team_lanes"] = false;
    root["ll"]["inference"] = "eigen";
    root["hl"]["explore"] = explore;
    root["hl"]["critic"] = "shared";
    root["hl"]["team_target"] = "sum";
    root["hl"]["lateral"] = "aircraft";
    root["hl"]["team_explore_scale"] = 1;
    root["hl"]["inference"] = "eigen";
    root["train"]["hl_average_share"] = 0;
    root["train"]["tail_member"] = 0;
    root["pool"]["p_center"] = 0;
    YAML::Emitter out;
    out << root;
    const std::string yaml = std::string(out.c_str()) + "\n";
    io::write_file_atomic(dir + "/config.yaml", yaml);
    const std::string meta_path = dir + "/checkpoint/" + latest_checkpoint_name(dir) + "/meta.yaml";
    std::ifstream in(meta_path);
    std::string meta((std::istreambuf_iterator<char>(in)), std::istreambuf_iterator<char>());
    const std::size_t at = meta.find("config_hash: ") + 13;
    meta = meta.substr(0, at) + std::to_string(config_hash(yaml)) + meta.substr(meta.find('\n', at));
    io::write_file_atomic(meta_path, meta);
    return yaml;
  };
  const std::string refused = fresh_dir("retired_refused");
  fs::copy(split, refused, fs::copy_options::recursive);
  fs::remove(refused + "/.lock");
  const std::string old_yaml = as_older_build(split, "aircraft");
  ASSERT_NE(old_yaml.find("goal_origin: center"), std::string::npos);
  auto resumed = Trainer::resume(split);
  EXPECT_EQ(resumed->updates(), 4);
  const TrainSummary rest = resumed->run();
  EXPECT_EQ(rest.updates, full.updates);
  EXPECT_EQ(resumed->ll_parameters(), a.ll_parameters());
  EXPECT_EQ(resumed->hl_parameters(), a.hl_parameters());
  resumed.reset();
  std::ifstream f(split + "/config.yaml");
  EXPECT_EQ(std::string((std::istreambuf_iterator<char>(f)), std::istreambuf_iterator<char>()), old_yaml);
  const RunPolicy p = load_run_policy(split);
  EXPECT_EQ(p.env_steps, full.env_steps);
  EXPECT_EQ(p.config.hl.epsilon, smoke().hl.epsilon);
  as_older_build(refused, "team");
  const std::string want = refused + "/config.yaml: hl.explore: team was removed, measured not to help";
  for (int use = 0; use < 2; ++use) {
    try {
      if (use == 0) Trainer::resume(refused);
      else load_run_policy(refused);
      ADD_FAILURE() << "a run trained with hl.explore: team was " << (use == 0 ? "resumed" : "loaded");
    } catch (const io::ConfigError& e) {
      const std::string what = e.what();
      EXPECT_EQ(what.rfind(want, 0), 0u) << what;
      EXPECT_NE(what.find("; build commit b8c9f8c to use it"), std::string::npos) << what;
    }
  }
}

// Races against the center-line control (pool.p_center_tail, in the HL-only tail): the setting
// changes the run, and the envs' opponent kind survives a checkpoint inside the tail (a resumed run
// ends with the unbroken run's weights).
TEST(Trainer, CenterControlOpponentsChangeTheRunAndResumeExactly) {
  const std::string plain = fresh_dir("ctr_plain"), whole = fresh_dir("ctr_whole"), split = fresh_dir("ctr_split");
  const TrainConfig tail = smoke("train.hl_tail_share=0.5");
  TrainConfig centered = tail;
  centered.pool.p_center_tail = 0.6;
  Trainer p(tail, plain);
  p.run();
  Trainer a(centered, whole);
  const TrainSummary full = a.run();
  EXPECT_NE(a.hl_parameters(), p.hl_parameters());
  EXPECT_EQ(a.ll_parameters(), p.ll_parameters());  // the tail's races only: the low level is frozen there
  std::int64_t in_tail = 0;  // the updates before the last one, inside the tail (env steps >= 300)
  while (full.rows.at(static_cast<std::size_t>(in_tail)).env_steps < 300) ++in_tail;
  ASSERT_LT(in_tail + 2, full.updates);
  {
    Trainer b(centered, split);
    b.run(nullptr, in_tail + 2);
  }
  auto resumed = Trainer::resume(split);
  resumed->run();
  EXPECT_EQ(resumed->updates(), full.updates);
  EXPECT_EQ(resumed->ll_parameters(), a.ll_parameters());
  EXPECT_EQ(resumed->hl_parameters(), a.hl_parameters());
}

// metrics.csv's airspeed column holds the learner's mean airspeed (an F-16 racing: hundreds of
// ft/s) and the middle-bin shares are shares; a run written by a build without these columns and
// without the checkpoint key that carries the shares, resumed, gets today's header with the
// columns empty in its old rows (every row keeps the header's width) and resumes.
TEST(Trainer, MetricsNewColumnsAndAnOlderRunUpgradedOnResume) {
  const std::string dir = fresh_dir("metrics_upgrade");
  {
    Trainer t(smoke(), dir);
    t.run(nullptr, 3);  // LL, LL, HL: the last row follows an ES update
  }
  const std::string path = dir + "/metrics.csv";
  const auto read_lines = [&] {
    std::vector<std::string> out;
    std::ifstream in(path);
    for (std::string l; std::getline(in, l);) out.push_back(l);
    return out;
  };
  const auto cells = [](const std::string& l) {
    std::vector<std::string> out;
    std::string c;
    std::istringstream in(l);
    while (std::getline(in, c, ',')) out.push_back(c);
    if (!l.empty() && l.back() == ',') out.push_back("");
    return out;
  };
  // An empty cell is a value the row does not have (the trainer writes nan as nothing).
  const auto number = [](const std::string& c) { return c.empty() ? std::nan("") : std::stod(c); };
  const std::vector<std::string> lines = read_lines();
  ASSERT_EQ(lines.size(), 4u);
  const std::string header = lines[0];
  const std::vector<std::string> names = cells(header);
  const std::vector<std::string> added = {"airspeed_ftps",  "middle_share_x",      "middle_share_y",
                                          "middle_share_z", "term_team_collision", "term_envelope"};
  ASSERT_GE(names.size(), added.size());
  ASSERT_TRUE(std::equal(added.begin(), added.end(), names.end() - static_cast<long>(added.size()))) << header;
  const std::size_t first_added = names.size() - added.size();
  for (std::size_t k = 1; k < lines.size(); ++k) {
    const std::vector<std::string> row = cells(lines[k]);
    ASSERT_EQ(row.size(), names.size()) << lines[k];
    const double v = std::stod(row[first_added]);
    EXPECT_GT(v, 300.0);
    EXPECT_LT(v, 1500.0);
    for (std::size_t j = first_added + 1; j < names.size(); ++j) {
      const double share = number(row[j]);
      if (k < 3) {
        EXPECT_TRUE(std::isnan(share)) << "no ES update yet, row " << k;
      } else {
        EXPECT_GE(share, 0.0);
        EXPECT_LE(share, 1.0);
        // At most 3 teams x 2 aircraft took the decision: a share is k / n with n <= 6.
        EXPECT_NEAR(share * 60.0, std::round(share * 60.0), 1e-9) << names[j] << " = " << share;
      }
    }
  }
  {  // as the previous build wrote it: no added columns ...
    std::ofstream out(path, std::ios::trunc);
    for (const std::string& l : lines) {
      std::size_t cut = l.size();
      for (std::size_t k = 0; k < added.size(); ++k) cut = l.rfind(',', cut - 1);
      out << l.substr(0, cut) << "\n";
    }
  }
  {  // ... and no checkpoint key for the shares
    std::ifstream latest(dir + "/checkpoint/LATEST");
    std::string name;
    latest >> name;
    const std::string ck = dir + "/checkpoint/" + name + "/trainer.pt";
    torch::serialize::InputArchive in;
    in.load_from(ck);
    torch::serialize::OutputArchive out;
    bool had_key = false;
    for (const std::string& key : in.keys()) {
      if (key == "last_middle_share") {
        had_key = true;
        continue;
      }
      torch::Tensor t;
      in.read(key, t);
      out.write(key, t);
    }
    ASSERT_TRUE(had_key);
    out.save_to(ck);
  }
  Trainer::resume(dir)->run(nullptr, 2);
  const std::vector<std::string> now = read_lines();
  ASSERT_EQ(now.size(), 6u);
  EXPECT_EQ(now[0], header);
  const auto commas = [](const std::string& l) { return std::count(l.begin(), l.end(), ','); };
  for (const std::string& l : now) EXPECT_EQ(commas(l), commas(header)) << l;
  EXPECT_EQ(now[1].substr(now[1].size() - 4), ",,,,");  // an old row: the new columns empty
  const std::vector<std::string> last = cells(now[5]);
  EXPECT_GT(std::stod(last[first_added]), 300.0);
  // The last ES update's shares came from a checkpoint without them: unknown, not made up.
  for (std::size_t j = first_added + 1; j < names.size(); ++j) EXPECT_TRUE(std::isnan(number(last[j]))) << names[j];
}

TEST(Trainer, RefusesToOverwriteARunAndRefusesACorruptCheckpoint) {
  const std::string dir = fresh_dir("corrupt");
  {
    Trainer t(smoke(), dir);
    t.run(nullptr, 3);
  }
  EXPECT_THROW(Trainer(smoke(), dir), std::runtime_error);
  std::ifstream latest(dir + "/checkpoint/LATEST");
  std::string name;
  latest >> name;
  const fs::path ck = fs::path(dir) / "checkpoint" / name / "trainer.pt";
  const auto size = fs::file_size(ck);
  fs::resize_file(ck, size / 2);  // a torn write that the atomic rename would have prevented
  try {
    Trainer::resume(dir);
    FAIL() << "a truncated checkpoint was accepted";
  } catch (const std::runtime_error& e) {
    EXPECT_NE(std::string(e.what()).find("cannot resume from this checkpoint"), std::string::npos) << e.what();
    EXPECT_NE(std::string(e.what()).find(name), std::string::npos) << e.what();
    // One line naming the file and the fix, not LibTorch's backtrace.
    EXPECT_NE(std::string(e.what()).find(name + "/trainer.pt: "), std::string::npos) << e.what();
    EXPECT_NE(std::string(e.what()).find("restore it or train again"), std::string::npos) << e.what();
    EXPECT_EQ(std::string(e.what()).find('\n'), std::string::npos) << e.what();
  }
  EXPECT_EQ(fs::file_size(ck), size / 2);  // nothing was overwritten by the failed attempt
}

// Issue 15, reproduction 1: a run whose LATEST is missing was silently replaced by a fresh one.
TEST(Trainer, RunWithoutLatestIsNeverOverwrittenByAFreshRun) {
  const std::string dir = fresh_dir("no_latest");
  {
    Trainer t(smoke(), dir);
    t.run(nullptr, 3);
  }
  fs::remove(fs::path(dir) / "checkpoint" / "LATEST");
  const auto config_before = fs::last_write_time(fs::path(dir) / "config.yaml");
  const auto metrics_size = fs::file_size(fs::path(dir) / "metrics.csv");
  try {
    Trainer(smoke("seed=4"), dir);
    FAIL() << "a fresh run replaced a run folder without LATEST";
  } catch (const std::runtime_error& e) {
    const std::string m = e.what();
    EXPECT_NE(m.find("already holds a run (checkpoint, config.yaml, curves"), std::string::npos) << m;
    EXPECT_NE(m.find("--overwrite"), std::string::npos) << m;
  }
  EXPECT_EQ(fs::last_write_time(fs::path(dir) / "config.yaml"), config_before);
  EXPECT_EQ(fs::file_size(fs::path(dir) / "metrics.csv"), metrics_size);
  EXPECT_FALSE(fs::is_empty(fs::path(dir) / "pool"));
}

// Issue 15, reproduction 2: two writers on one folder interleaved configs, checkpoints and rows.
TEST(Trainer, SecondTrainerOnALiveRunFolderIsRefused) {
  const std::string dir = fresh_dir("two_writers");
  Trainer first(smoke(), dir);
  first.run(nullptr, 3);
  for (int attempt = 0; attempt < 2; ++attempt) {
    try {
      if (attempt == 0)
        Trainer(smoke("seed=2"), dir);
      else
        Trainer::resume(dir);
      FAIL() << "a second writer was let into a live run folder";
    } catch (const std::runtime_error& e) {
      EXPECT_NE(std::string(e.what()).find("is in use by another f16race train (pid "), std::string::npos) << e.what();
    }
  }
  EXPECT_EQ(first.run(nullptr, 3).updates, 6);  // the owner carries on undisturbed
}

// Issue 15, full disk: a checkpoint that cannot be written is removed whole, LATEST keeps naming
// the previous one, no temporary is left, and the run resumes from it.
TEST(Trainer, FullDiskDuringACheckpointKeepsTheLastOneAndResumes) {
  const std::string dir = fresh_dir("full_disk");
  std::string latest_before;
  {
    Trainer t(smoke(), dir);
    t.run(nullptr, 3);
    latest_before = latest_checkpoint_name(dir);
    ASSERT_FALSE(latest_before.empty());
    rlimit old{};
    getrlimit(RLIMIT_FSIZE, &old);
    auto* old_handler = std::signal(SIGXFSZ, SIG_IGN);
    rlimit small = old;
    small.rlim_cur = 12 * 1024;  // metrics rows fit; networks and the env state do not
    setrlimit(RLIMIT_FSIZE, &small);
    std::string message;
    try {
      t.run(nullptr, 9);
    } catch (const io::FileWriteError& e) {
      message = e.what();
    }
    setrlimit(RLIMIT_FSIZE, &old);
    std::signal(SIGXFSZ, old_handler);
    EXPECT_NE(message.find("file too large while writing; nothing else was changed"), std::string::npos) << message;
  }
  EXPECT_EQ(latest_checkpoint_name(dir), latest_before);
  int checkpoints = 0;
  for (const auto& e : fs::recursive_directory_iterator(dir)) {
    EXPECT_EQ(e.path().filename().string().find(".tmp"), std::string::npos) << e.path();
    if (e.is_directory() && e.path().parent_path().filename() == "checkpoint") ++checkpoints;
    if (e.is_directory() && e.path().parent_path().filename() == "pool") {  // no half snapshot
      EXPECT_TRUE(fs::exists(e.path() / "ll.pt") && fs::exists(e.path() / "hl.pt")) << e.path();
    }
  }
  EXPECT_EQ(checkpoints, 1);
  auto resumed = Trainer::resume(dir);
  EXPECT_EQ(resumed->updates(), 3);
}

TEST(Trainer, LatestEditedByHandWithATrailingNewlineStillResumes) {
  const std::string dir = fresh_dir("latest_newline");
  {
    Trainer t(smoke(), dir);
    t.run(nullptr, 3);
  }
  const std::string name = latest_checkpoint_name(dir);
  ASSERT_FALSE(name.empty());
  std::ofstream(dir + "/checkpoint/LATEST", std::ios::trunc) << name << "\n";
  EXPECT_EQ(latest_checkpoint_name(dir), name);
  EXPECT_EQ(Trainer::resume(dir)->updates(), 3);
  fs::remove(fs::path(dir) / "checkpoint" / "LATEST");
  EXPECT_EQ(latest_checkpoint_name(dir), "");
  // A lost LATEST beside a checkpoint folder is refused, naming the folder, and nothing goes.
  try {
    Trainer::resume(dir);
    FAIL() << "resumed without LATEST";
  } catch (const std::runtime_error& e) {
    EXPECT_NE(std::string(e.what()).find("beside checkpoint folder(s) " + name), std::string::npos) << e.what();
  }
  EXPECT_TRUE(fs::is_directory(fs::path(dir) / "checkpoint" / name));
}

TEST(Trainer, RefusesACheckpointWrittenWithAnotherConfig) {
  const std::string dir = fresh_dir("mismatch");
  {
    Trainer t(smoke(), dir);
    t.run(nullptr, 3);
  }
  std::ofstream(dir + "/config.yaml", std::ios::app) << "# edited\n";
  try {
    Trainer::resume(dir);
    FAIL() << "a mismatched config was accepted";
  } catch (const std::runtime_error& e) {
    EXPECT_NE(std::string(e.what()).find("different config.yaml"), std::string::npos) << e.what();
  }
}

// A checkpoint of the previous format (its meta.yaml says so) is refused by name before any
// of its bytes are read as this build's layout.
TEST(Trainer, RefusesACheckpointOfThePreviousFormat) {
  const std::string dir = fresh_dir("old_format");
  {
    Trainer t(smoke(), dir);
    t.run(nullptr, 3);
  }
  const std::string meta = dir + "/checkpoint/" + latest_checkpoint_name(dir) + "/meta.yaml";
  YAML::Node m = YAML::LoadFile(meta);
  m["format"] = kCheckpointFormat - 1;
  std::ofstream(meta, std::ios::trunc) << m;
  try {
    Trainer::resume(dir);
    FAIL() << "a previous-format checkpoint was accepted";
  } catch (const std::runtime_error& e) {
    const std::string want = "checkpoint format " + std::to_string(kCheckpointFormat - 1) + ", this build reads " +
                             std::to_string(kCheckpointFormat) + " to resume";
    EXPECT_NE(std::string(e.what()).find(want), std::string::npos) << e.what();
    EXPECT_EQ(std::string(e.what()).find('\n'), std::string::npos) << "one line";
  }
  // Its networks are unchanged since kOldestPolicyFormat: still raced, replayed and exported.
  EXPECT_GT(check_checkpoint_meta(fs::path(meta).parent_path().string(), read_run_config(dir).hash,
                                  CheckpointUse::policy),
            0);
  m["format"] = kOldestPolicyFormat - 1;
  std::ofstream(meta, std::ios::trunc) << m;
  EXPECT_THROW(check_checkpoint_meta(fs::path(meta).parent_path().string(), read_run_config(dir).hash,
                                     CheckpointUse::policy),
               std::runtime_error);
}

// Issue 48: a kill at any instant leaves a resumable run. The run folder is copied as it stands
// after every update's metrics row (where a SIGKILL could land between writes) and each copy is
// resumed to the end: the pool snapshots its last checkpoint names must all still be there (they
// were pruned as soon as a newer one was taken), and every resumed run ends as the whole run did.
TEST(Trainer, ACopyOfTheRunFolderAtAnyUpdateResumesToTheSameEnd) {
  const std::string extra = "train.checkpoint_every_updates=7";
  TrainConfig cfg = smoke(extra);
  cfg.pool.snapshot_every_updates = 1;
  cfg.pool.max_snapshots = 2;
  cfg.loop.total_env_steps = 1200;
  const std::string dir = fresh_dir("kill_copies");
  std::vector<std::string> copies;
  std::vector<float> ll_whole, hl_whole;
  {
    Trainer t(cfg, dir);
    t.run(nullptr, -1, [&](const MetricsRow& r) {
      const std::string copy = dir + "_at" + std::to_string(r.update);
      fs::remove_all(copy);
      copy_live_run_folder(dir, copy);
      fs::remove(fs::path(copy) / ".lock");
      copies.push_back(copy);
    });
    ll_whole = t.ll_parameters();
    hl_whole = t.hl_parameters();
  }
  ASSERT_GE(copies.size(), 15u);
  int resumed = 0;
  for (const std::string& copy : copies) {
    if (latest_checkpoint_name(copy).empty()) continue;  // before the first checkpoint: the next test
    auto t = Trainer::resume(copy);
    t->run(nullptr, -1);
    EXPECT_EQ(t->ll_parameters(), ll_whole) << copy;
    EXPECT_EQ(t->hl_parameters(), hl_whole) << copy;
    // Only what the last checkpoint names is left in the pool: max_snapshots and its opponent.
    int snapshots = 0;
    for (const auto& e : fs::directory_iterator(fs::path(copy) / "pool")) snapshots += e.is_directory();
    EXPECT_LE(snapshots, cfg.pool.max_snapshots + 1) << copy;
    ++resumed;
  }
  EXPECT_GE(resumed, 10);
}

// Killed before its first checkpoint, a run folder holds its config, the first pool snapshot and
// maybe metrics rows: --resume starts it afresh and it ends as an uninterrupted run.
TEST(Trainer, ARunResumedBeforeItsFirstCheckpointStartsAfresh) {
  const std::string whole = fresh_dir("first_whole"), killed = fresh_dir("first_killed");
  Trainer a(smoke(), whole);
  a.run(nullptr, 4);
  { Trainer b(smoke(), killed); }  // set up, never stepped: no checkpoint
  std::ofstream(killed + "/metrics.csv") << "update,garbage\n1,2\n";
  ASSERT_TRUE(latest_checkpoint_name(killed).empty());
  auto b = Trainer::resume(killed);
  EXPECT_EQ(b->updates(), 0);
  b->run(nullptr, 4);
  EXPECT_EQ(b->ll_parameters(), a.ll_parameters());
  EXPECT_EQ(b->hl_parameters(), a.hl_parameters());
  // Killed while its first checkpoint was written (the folder is there, LATEST still empty): the
  // uncommitted folder goes and the run starts afresh.
  const std::string first_ck = fresh_dir("first_ck");
  {
    Trainer c(smoke(), first_ck);
    c.run(nullptr, 3);
  }
  const std::string uncommitted = latest_checkpoint_name(first_ck);
  io::write_file_atomic(first_ck + "/checkpoint/LATEST", "");
  auto c = Trainer::resume(first_ck);
  EXPECT_EQ(c->updates(), 0);
  EXPECT_FALSE(fs::exists(fs::path(first_ck) / "checkpoint" / uncommitted));
  c->run(nullptr, 4);
  EXPECT_EQ(c->ll_parameters(), a.ll_parameters());
  // A folder that never got its config is not a run: resume says how to start one.
  const std::string empty = fresh_dir("first_empty");
  fs::create_directories(fs::path(empty) / "checkpoint");
  try {
    Trainer::resume(empty);
    FAIL() << "resumed a folder without a config";
  } catch (const std::runtime_error& e) {
    EXPECT_NE(std::string(e.what()).find("holds no run yet"), std::string::npos) << e.what();
    EXPECT_NE(std::string(e.what()).find("--run " + empty), std::string::npos) << e.what();
  }
}

// What a killed writer left (file and figure temporaries, a half pool snapshot) is removed by the
// next process that owns the run folder; a live process's temporaries are left alone.
TEST(Trainer, AResumeRemovesTheTemporariesOfKilledWriters) {
  const std::string dir = fresh_dir("stale");
  {
    Trainer t(smoke(), dir);
    t.run(nullptr, 3);
  }
  const pid_t child = fork();
  if (child == 0) _exit(0);
  waitpid(child, nullptr, 0);
  const std::string dead = std::to_string(child), live = std::to_string(getppid());  // alive, not this process
  const std::vector<std::string> stale = {"config.yaml.tmp." + dead, ".curves.png.tmp." + dead + ".1",
                                          "checkpoint/LATEST.tmp." + dead, "pool/.step_0000000096.tmp." + dead};
  for (const std::string& f : stale) {
    if (f.rfind("pool/", 0) == 0) fs::create_directories(fs::path(dir) / f);
    else std::ofstream(fs::path(dir) / f) << "half";
  }
  std::ofstream(fs::path(dir) / ("metrics.csv.tmp." + live)) << "live";
  Trainer::resume(dir);
  for (const std::string& f : stale) EXPECT_FALSE(fs::exists(fs::path(dir) / f)) << f;
  EXPECT_TRUE(fs::exists(fs::path(dir) / ("metrics.csv.tmp." + live)));
}

TEST(Trainer, AtomicCheckpointsLeaveNoTemporaryFilesAndPruneOldOnes) {
  const std::string dir = fresh_dir("atomic");
  Trainer t(smoke(), dir);
  t.run(nullptr, 7);
  int folders = 0;
  for (const auto& e : fs::directory_iterator(fs::path(dir) / "checkpoint")) {
    EXPECT_EQ(e.path().string().find(".tmp"), std::string::npos) << e.path();
    folders += e.is_directory();
  }
  EXPECT_EQ(folders, 1);
  int pool = 0;
  for (const auto& e : fs::directory_iterator(fs::path(dir) / "pool")) pool += e.is_directory();
  EXPECT_EQ(pool, 2);  // max_snapshots
  // The learning curves follow the checkpoints: data and script always, the figure with gnuplot.
  const TrainSummary more = t.run(nullptr, 1);
  EXPECT_TRUE(fs::exists(fs::path(dir) / "curves_data.csv"));
  EXPECT_TRUE(fs::exists(fs::path(dir) / "curves.gp"));
  if (more.curves_problem.empty()) {
    EXPECT_GT(fs::file_size(fs::path(dir) / "curves.png"), 1000u);
  }
  for (const auto& e : fs::directory_iterator(dir)) EXPECT_EQ(e.path().string().find(".tmp"), std::string::npos) << e.path();
  EXPECT_GT(more.hl_grad_steps, 0);  // smoke: 1 ES update in every 3, 8 x 8 steps on 3 teams each
}

TEST(SelfPlay, MatchupAndPoolDrawFrequencies) {
  RandomStream s(5, 1);
  PoolConfig p;
  p.p_self_play = 0.5;
  const int n = 40000;
  int red = 0, pool = 0;
  for (int k = 0; k < n; ++k) {
    const Matchup m = draw_matchup(s, p, true);
    red += m.learner_side;
    pool += m.vs_pool;
  }
  EXPECT_NEAR(red / double(n), 0.5, 0.01);
  EXPECT_NEAR(pool / double(n), 0.5, 0.01);
  p.p_self_play = 0.8;
  pool = 0;
  for (int k = 0; k < n; ++k) pool += draw_matchup(s, p, true).vs_pool;
  EXPECT_NEAR(pool / double(n), 0.2, 0.01);
  for (int k = 0; k < 1000; ++k) EXPECT_FALSE(draw_matchup(s, p, false).vs_pool);
  int count[5] = {};
  for (int k = 0; k < 50000; ++k) ++count[draw_pool_entry(s, 5)];
  for (int c : count) EXPECT_NEAR(c / 50000.0, 0.2, 0.01);
}

TEST(SelfPlay, CenterControlShareComesFirstAndSplitsTheRest) {
  PoolConfig p;
  p.p_self_play = 0.5;
  p.p_center_tail = 0.3;
  RandomStream s(9, 2);
  const int n = 40000;
  int center = 0, pool = 0, both = 0;
  for (int k = 0; k < n; ++k) {
    const Matchup m = draw_matchup(s, p, true, /*in_tail=*/true);
    center += m.vs_center;
    pool += m.vs_pool;
    both += m.vs_center && m.vs_pool;
  }
  EXPECT_EQ(both, 0);
  EXPECT_NEAR(center / double(n), 0.3, 0.01);
  EXPECT_NEAR(pool / double(n), 0.35, 0.01);  // half of the other 70 %
  // Without the pool, the center share stays and the rest is self-play.
  center = 0;
  for (int k = 0; k < n; ++k) {
    const Matchup m = draw_matchup(s, p, false, true);
    EXPECT_FALSE(m.vs_pool);
    center += m.vs_center;
  }
  EXPECT_NEAR(center / double(n), 0.3, 0.01);
  // Before the tail: the paper's draws, none against the center line; the stream advances as in it.
  p.p_center_tail = 0.8;
  RandomStream t1(4, 1), t2(4, 1);
  center = 0;
  int before_center = 0, before_pool = 0;
  for (int k = 0; k < n; ++k) {
    const Matchup in_tail = draw_matchup(t1, p, true, true);
    const Matchup before = draw_matchup(t2, p, true, false);
    EXPECT_EQ(in_tail.learner_side, before.learner_side);
    center += in_tail.vs_center;
    before_center += before.vs_center;
    before_pool += before.vs_pool;
  }
  EXPECT_NEAR(center / double(n), 0.8, 0.01);
  EXPECT_EQ(before_center, 0);
  EXPECT_NEAR(before_pool / double(n), 0.5, 0.01);
}

}  // namespace
}  // namespace f16race::train
