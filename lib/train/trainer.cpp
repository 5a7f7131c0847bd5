#include "train/trainer.hpp"

#include <torch/torch.h>
#include <yaml-cpp/yaml.h>

#include <algorithm>
#include <chrono>
#include <cmath>
#include <cstdio>
#include <filesystem>
#include <fstream>
#include <functional>
#include <optional>
#include <sstream>
#include <stdexcept>

#include "io/input_error.hpp"
#include "agents/checkpoint.hpp"
#include "dist/process_group.hpp"
#include "io/atomic_file.hpp"
#include "io/csv_table.hpp"
#include "io/learning_curves.hpp"
#include "io/run_folder.hpp"
#include "io/stale_temporaries.hpp"
#include "io/yaml_config.hpp"
#include "race/race_env.hpp"
#include "random/random_stream.hpp"
#include "train/obs_views.hpp"
#include "train/policy_rows.hpp"
#include "train/snapshot_pool.hpp"

namespace f16race::train {

namespace fs = std::filesystem;
using models::HlObs;
using models::LlObs;

namespace {

std::string read_text(const std::string& path) {
  std::ifstream f(path, std::ios::binary);
  if (!f) throw io::InputError(path + ": cannot read");
  std::stringstream ss;
  ss << f.rdbuf();
  return ss.str();
}

torch::Tensor bytes_tensor(const std::string& bytes) {
  auto t = torch::empty({static_cast<std::int64_t>(bytes.size())}, torch::kUInt8);
  std::memcpy(t.data_ptr(), bytes.data(), bytes.size());
  return t;
}

std::string tensor_bytes(const torch::Tensor& t) {
  const auto c = t.contiguous();
  return std::string(static_cast<const char*>(c.data_ptr()), static_cast<std::size_t>(c.numel()));
}

std::vector<float> flat_parameters(const torch::nn::Module& m) {
  std::vector<float> out;
  for (const auto& p : m.parameters()) {
    const auto c = p.detach().contiguous().to(torch::kFloat32);
    out.insert(out.end(), c.data_ptr<float>(), c.data_ptr<float>() + c.numel());
  }
  return out;
}

}  // namespace

// Open high-level decisions of the learner team, one slot per env.
// The two sides of Trainer::State::visit_checkpoint: each key is written by one and read back
// by the other from the same list, so saving and loading cannot drift apart.
struct CheckpointWriter {
  torch::serialize::OutputArchive a;
  void tensor(const char* key, torch::Tensor& t) { a.write(key, t); }
  template <class... T>
  void integers(const char* key, T&... x) {
    a.write(key, torch::tensor(std::vector<std::int64_t>{static_cast<std::int64_t>(x)...}));
  }
  // Double precision explicitly: torch::tensor of doubles would default to float32.
  template <class... T>
  void reals(const char* key, T&... x) {
    a.write(key, torch::tensor(std::vector<double>{x...}, torch::kFloat64));
  }
  template <class T>
  void integer_list(const char* key, std::vector<T>& v, bool /*fixed_size*/) {
    a.write(key, torch::tensor(std::vector<std::int64_t>(v.begin(), v.end()), torch::kInt64));
  }
  template <class... T>
  void optional_reals(const char* key, T&... x) {
    reals(key, x...);
  }
  void real_list(const char* key, std::vector<double>& v) { a.write(key, torch::tensor(v, torch::kFloat64)); }
  void bytes(const char* key, const std::function<void(std::ostream&)>& save, const std::function<void(std::istream&)>&) {
    std::ostringstream out;
    save(out);
    a.write(key, bytes_tensor(out.str()));
  }
};

struct CheckpointReader {
  torch::serialize::InputArchive a;
  // A fresh tensor per key: reading into a defined tensor would reuse (and reinterpret) it.
  torch::Tensor get(const char* key, std::int64_t want_numel = -1) {
    torch::Tensor t;
    a.read(key, t);
    TORCH_CHECK(want_numel < 0 || t.numel() == want_numel, "'", key, "' holds ", t.numel(), " values, expected ",
                want_numel, " (another config?)");
    return t;
  }
  void tensor(const char* key, torch::Tensor& t) { t.copy_(get(key, t.numel())); }
  template <class... T>
  void integers(const char* key, T&... x) {
    const torch::Tensor t = get(key, sizeof...(T)).to(torch::kInt64).contiguous();
    const std::int64_t* p = t.data_ptr<std::int64_t>();
    std::size_t k = 0;
    ((x = static_cast<T>(p[k++])), ...);
  }
  template <class... T>
  void reals(const char* key, T&... x) {
    const torch::Tensor t = get(key, sizeof...(T)).to(torch::kFloat64).contiguous();
    const double* p = t.data_ptr<double>();
    std::size_t k = 0;
    ((x = p[k++]), ...);
  }
  // A key newer than some checkpoints: absent, the values are left as they are.
  template <class... T>
  void optional_reals(const char* key, T&... x) {
    torch::Tensor t;
    if (!a.try_read(key, t)) return;
    TORCH_CHECK(t.numel() == static_cast<std::int64_t>(sizeof...(T)), "'", key, "' holds ", t.numel(),
                " values, expected ", sizeof...(T));
    t = t.to(torch::kFloat64).contiguous();
    const double* p = t.data_ptr<double>();
    std::size_t k = 0;
    ((x = p[k++]), ...);
  }
  template <class T>
  void integer_list(const char* key, std::vector<T>& v, bool fixed_size) {
    const torch::Tensor t = get(key, fixed_size ? static_cast<std::int64_t>(v.size()) : -1).to(torch::kInt64).contiguous();
    const std::int64_t* p = t.data_ptr<std::int64_t>();
    v.assign(p, p + t.numel());
  }
  void real_list(const char* key, std::vector<double>& v) {
    const torch::Tensor t = get(key, static_cast<std::int64_t>(v.size())).to(torch::kFloat64).contiguous();
    v.assign(t.data_ptr<double>(), t.data_ptr<double>() + t.numel());
  }
  void bytes(const char* key, const std::function<void(std::ostream&)>&, const std::function<void(std::istream&)>& load) {
    std::istringstream in(tensor_bytes(get(key)));
    load(in);
  }
};

struct OpenHl {
  HlObs obs;                  // fields [n_env, team_size, ...]
  torch::Tensor actions;      // [n_env, ts, 3] int64
  torch::Tensor reward;       // [n_env, ts] float32, accumulated since the decision
  torch::Tensor active;       // [n_env, ts] bool
  std::vector<std::uint8_t> open;  // [n_env]
};

struct Trainer::State {
  // Declared first, so released last: no other process writes the folder while this one lives.
  std::unique_ptr<io::RunFolderLock> lock;
  // Data-parallel ranks (issue 18): null or size 1 for one process. Rank 0 writes the run folder.
  dist::Group* group = nullptr;
  int rank = 0, world = 1;
  TrainConfig cfg;
  std::string run_dir;
  std::string resolved_yaml;
  std::uint64_t hash = 0;
  std::unique_ptr<race::RaceEnv> env;
  std::unique_ptr<agents::PpoAgent> ppo, opp_ppo;
  std::unique_ptr<agents::EsAgent> es, opp_es;
  std::unique_ptr<agents::RolloutBuffer> buffer;
  PolicyRows ll_rows{2, 0}, hl_rows{2, 0};  // [n_env * n_agent] learner (0) and pool (1) rows
  at::Generator gen;
  RandomStream stream{1, 0xC0FFEE};
  // The HL-only tail's first update has begun (start_tail): a tail member's streams are switched,
  // an ensemble's members forked. Kept in trainer.pt only by runs with either.
  bool tail_started = false;
  int n_env = 0, n_agent = 0, ts = 0;  // n_env: this rank's envs
  int n_env_global = 0;                // race.n_env: the group's
  models::ObsDims dims;

  // Counters.
  std::int64_t env_steps = 0, ppo_updates = 0, es_updates = 0, hl_grad_steps = 0;
  std::int64_t rank_env_steps = 0;  // this rank's own, in this process (not checkpointed)
  int phase = 0;               // 0: low level learns, 1: high level learns
  int phase_updates = 0;       // updates done in the current phase
  std::int64_t opponent = -1;  // pool snapshot (its env_steps) the pool envs play, -1: none
  SnapshotPool pool{"", 0, false};  // set up by build()
  std::vector<int> side;       // [n_env] learner team
  // [n_env] who the opponent is: kVsSelf the current policy, kVsPool the pool snapshot,
  // kVsCenter the current low level with a center-line high level (pool.p_center_tail).
  std::vector<std::uint8_t> vs_pool;
  enum : std::uint8_t { kVsSelf = 0, kVsPool = 1, kVsCenter = 2 };

  // HL transitions.
  OpenHl open;
  std::vector<HlObs> done_obs, done_next;
  std::vector<torch::Tensor> done_actions, done_reward, done_flag, done_active, done_next_active;

  // Metrics accumulators since the last row.
  std::vector<double> ll_ret, hl_ret;  // [n_env * ts] running returns of learner aircraft
  double sum_ll_ret = 0, sum_hl_ret = 0, n_ret = 0, n_hl_ret = 0, sum_goal = 0, n_goal = 0, sum_vt = 0, n_vt = 0;
  double races = 0, wins = 0, finishes = 0, term[race::kNumCauses] = {};
  std::int64_t steps_at_row = 0;
  double wall_at_row = 0.0, wall_offset = 0.0;
  std::chrono::steady_clock::time_point t0 = std::chrono::steady_clock::now();
  agents::PpoStats last_ppo;
  agents::EsStats last_es;
  TimeBreakdown timing;
  NetworkWork work;
  std::string curves_problem;  // why the last curves.png could not be made (empty: it was)
  // When curves.png was last drawn (none yet: the first checkpoint draws it).
  std::optional<std::chrono::steady_clock::time_point> curves_drawn_at;
  // A draw under way (it holds its own copy of the folder's name) ends before the folder lock,
  // declared first, is released.
  io::BackgroundCurves curves;
  using Clock = std::chrono::steady_clock;
  static double since(Clock::time_point t) { return std::chrono::duration<double>(Clock::now() - t).count(); }

  double wall() const {
    return wall_offset + std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
  }
  int learner_agent(int e, int j) const { return e * n_agent + side[e] * ts + j; }
  // Which learner aircraft of env e count in an HL transition (docs/learning.md, "Elimination"):
  // the egoistic critics (es, es_d1) keep an eliminated aircraft in its own transitions to the
  // race's end (it is paid the team term; its bins have no effect); the team critics count the
  // aircraft alive at the decision and value the team's future through its living members.
  // At a race's end the env has already reset, so who was alive is read from `truncated`.
  torch::Tensor hl_members(int e, bool at_race_end = false) const {
    auto m = torch::ones({ts}, torch::kBool);
    if (agents::es_is_team(cfg.hl.variant))
      for (int j = 0; j < ts; ++j) {
        const int i = learner_agent(e, j);
        m.data_ptr<bool>()[j] = at_race_end ? env->truncated()[i] != 0 : env->alive(i);
      }
    return m;
  }
  bool is_learner(int e, int agent) const { return agent / ts == side[e]; }
  // Who flies each aircraft: 0 the learner's networks (its team, and both teams in self-play
  // envs), 1 the pool snapshot (the other team in pool envs); -1 where `only` is given and
  // its env's flag is down (an HL decision only for the envs that are due), and for the high
  // level of a center-line opponent (its rows keep the middle bin).
  std::vector<int> owners(const std::uint8_t* only = nullptr, bool high_level = false) const {
    std::vector<int> o(static_cast<std::size_t>(n_env) * n_agent);
    for (int e = 0; e < n_env; ++e)
      for (int a = 0; a < n_agent; ++a) {
        int who = 0;
        if (only && !only[e]) who = -1;
        else if (!is_learner(e, a) && vs_pool[e] == kVsPool) who = 1;
        else if (!is_learner(e, a) && vs_pool[e] == kVsCenter) who = high_level ? -1 : 0;
        o[e * n_agent + a] = who;
      }
    return o;
  }

  void build(bool fresh);
  bool writes() const { return rank == 0; }
  // Sums over the ranks, in place (nothing for one process).
  void group_sum(std::vector<double>& v) const;
  void group_sum(std::vector<std::int64_t>& v) const;
  // The ranks' networks are the same bits (they take the same steps): checked at every
  // checkpoint, so a broken invariant stops the run instead of training diverged replicas.
  void check_replicas_agree();
  torch::Tensor learner_index() const;
  LlObs ll_view(bool final_obs) const { return ll_obs_view(*env, final_obs); }
  HlObs hl_view(bool final_obs) const { return hl_obs_view(*env, final_obs); }
  void draw_matchup(int env);
  // The run has used its low level's share of the steps: only the high level learns from here
  // (train.hl_tail_share).
  bool in_hl_tail() const { return in_last_share(cfg.loop.hl_tail_share); }
  // In the tail with the low level frozen for good: the tail's matchups, and where its members'
  // streams begin (a run resumed inside an LL phase past the tail's share finishes that phase's
  // update first).
  bool in_frozen_tail() const { return in_hl_tail() && phase == 1; }
  // The run is a tail member (LoopConfig::tail_member) or forks some (train.hl_tail_members).
  bool has_tail_members() const { return cfg.loop.tail_member > 0 || cfg.loop.hl_tail_members > 1; }
  // The run is in the last `share` of its env steps (never, for a share of 0).
  bool in_last_share(double share) const {
    return share > 0.0 && static_cast<double>(env_steps) >= (1.0 - share) * static_cast<double>(cfg.loop.total_env_steps);
  }
  // At the first update of the HL-only tail. train.hl_tail_members K > 1: a checkpoint, then
  // fork_tail_members. A tail member m > 0: the env's track streams, the matchup stream, the
  // exploration generator and the ES minibatch order become member m's.
  void start_tail();
  // RUN/members/1..K-1 from the LATEST checkpoint: run folders of this config with tail_member m
  // (config.yaml, the checkpoint under its hash, the pool, metrics.csv), each made in a temporary
  // folder and renamed; a member folder that exists is kept (a resumed run forks once).
  void fork_tail_members();
  void hl_decisions();
  void close_open(int env, bool done, const HlObs& next_rows, const torch::Tensor& next_active);
  // Waits for the curves draw under way and keeps why it failed, if it did, for the summary.
  void collect_curves() {
    if (std::string problem = curves.wait(); !problem.empty()) curves_problem = problem;
  }
  // Starts a draw of the run's curves once the one under way has ended.
  void redraw_curves(std::chrono::steady_clock::time_point now) {
    collect_curves();
    curves_drawn_at = now;
    curves.start(run_dir);
  }
  void ll_step(bool learn);
  void ppo_update();
  void es_update();
  MetricsRow make_row(const char* phase_name);
  void write_row(const MetricsRow& r);
  void snapshot_pool();
  void load_opponent();
  void load_pool_snapshot();  // the pool's `opponent` into opp_ppo, opp_es
  // `last`: the run's final checkpoint (budget reached, stopped, or --max-updates), which always
  // redraws the learning curves.
  void save_checkpoint(bool last);
  void load_checkpoint();
  // A run folder resumed before its first checkpoint: everything but config.yaml (and the lock)
  // removed, so the run starts again.
  void clear_for_fresh_start();
  // train.ll_from: the named run's latest low level (weights and observation statistics).
  void load_frozen_low_level();
  // At a resume: checkpoint folders other than LATEST's (written, never committed) are removed.
  void remove_uncommitted_checkpoints() const;
  void truncate_metrics();
  // Everything trainer.pt holds, in one list both adapters walk. The clock and the stream are
  // passed as plain values: saved from wall() and stream.state(), restored by the caller.
  template <class V>
  void visit_checkpoint(V& v, double& wall_s, std::uint64_t& stream_state);
};

template <class V>
void Trainer::State::visit_checkpoint(V& v, double& wall_s, std::uint64_t& stream_state) {
  v.bytes("env", [&](std::ostream& out) { env->save_state(out); }, [&](std::istream& in) { env->load_state(in); });
  v.integers("counters", env_steps, ppo_updates, es_updates, phase, phase_updates, opponent, hl_grad_steps);
  v.integer_list("pool", pool.steps(), false);
  v.integer_list("side", side, true);
  v.integer_list("vs_pool", vs_pool, true);
  v.integers("stream", stream_state);
  v.tensor("open_ego", open.obs.ego);
  v.tensor("open_prev_action", open.obs.prev_action);
  v.tensor("open_ado", open.obs.ado);
  v.tensor("open_alive", open.obs.ado_alive);
  v.tensor("open_task", open.obs.task);
  v.tensor("open_actions", open.actions);
  v.tensor("open_reward", open.reward);
  v.tensor("open_active", open.active);
  v.integer_list("open_flag", open.open, true);
  v.real_list("returns", ll_ret);
  v.real_list("hl_returns", hl_ret);
  // The last updates' statistics, so metrics rows after a resume match an unbroken run.
  v.reals("last_stats", last_ppo.policy_loss, last_ppo.value_loss, last_ppo.entropy, last_ppo.approx_kl,
          last_ppo.learning_rate, last_es.loss, last_es.q_mean, last_es.end_atom_share, last_es.huber_share,
          last_es.q_spread, last_es.greedy_entropy, last_es.off_center_share, last_es.loss_before);
  // Added after the key above was fixed: checkpoints written before it resume with nan here.
  v.optional_reals("last_middle_share", last_es.middle_share[0], last_es.middle_share[1], last_es.middle_share[2]);
  v.reals("wall", wall_s);
  // Only with tail members, so the checkpoints of every other run keep their bytes.
  if (has_tail_members()) {
    double started = tail_started ? 1.0 : 0.0;
    v.optional_reals("tail_started", started);
    tail_started = started != 0.0;
  }
}

void Trainer::State::start_tail() {
  // The members start from the state before any of the tail's draws, with tail_started unset.
  if (cfg.loop.hl_tail_members > 1) {
    save_checkpoint(false);
    if (writes()) fork_tail_members();
  }
  if (cfg.loop.tail_member > 0) {
    const std::uint64_t m = static_cast<std::uint64_t>(cfg.loop.tail_member);
    env->reseed_streams(m);
    stream = RandomStream(cfg.seed, 0xC0FFEE + static_cast<std::uint64_t>(rank) + (m << 32));
    gen.set_current_seed(cfg.seed * 7919 + 3 + static_cast<std::uint64_t>(rank) * 1000003 + m * 0x9E3779B97F4A7C15ULL);
    es->minibatch_generator().set_current_seed(cfg.hl.seed + m * 0x9E3779B97F4A7C15ULL);
  }
  tail_started = true;
}

void Trainer::State::fork_tail_members() {
  const fs::path members = fs::path(run_dir) / "members";
  const std::string ck = latest_checkpoint_name(run_dir);
  const std::string meta = read_text((fs::path(run_dir) / "checkpoint" / ck / "meta.yaml").string());
  for (int m = 1; m < cfg.loop.hl_tail_members; ++m) {
    const fs::path dir = members / std::to_string(m);
    if (fs::exists(dir)) continue;
    const fs::path tmp = members / ("." + std::to_string(m) + ".tmp");
    fs::remove_all(tmp);
    fs::create_directories(tmp / "checkpoint");
    // The member's config is this run's as a single tail drawn from member m's streams.
    TrainConfig member = cfg;
    member.loop.tail_member = m;
    member.loop.hl_tail_members = 1;
    const std::string yaml = train_config_yaml(member);
    io::write_file_atomic((tmp / "config.yaml").string(), yaml);
    fs::copy(fs::path(run_dir) / "checkpoint" / ck, tmp / "checkpoint" / ck, fs::copy_options::recursive);
    const std::string key = "config_hash: ";
    const std::size_t at = meta.find(key), end = meta.find('\n', at);
    io::write_file_atomic((tmp / "checkpoint" / ck / "meta.yaml").string(),
                          meta.substr(0, at + key.size()) + std::to_string(config_hash(yaml)) + meta.substr(end));
    io::write_file_atomic((tmp / "checkpoint" / "LATEST").string(), ck);
    fs::copy(fs::path(run_dir) / "pool", tmp / "pool", fs::copy_options::recursive);
    fs::copy_file(fs::path(run_dir) / "metrics.csv", tmp / "metrics.csv");
    fs::rename(tmp, dir);
  }
}

Trainer::Trainer(std::unique_ptr<State> state) : s_(std::move(state)) {}
Trainer::~Trainer() = default;

namespace {
// Takes the run folder's lock, then removes what killed writers left in it: temporaries of
// files, figures and pool snapshots (uncommitted checkpoint folders go at the resume).
std::unique_ptr<io::RunFolderLock> own_run_folder(const std::string& run_dir) {
  auto lock = std::make_unique<io::RunFolderLock>(run_dir);
  for (const char* sub : {"", "checkpoint", "pool"}) io::remove_stale_temporaries((fs::path(run_dir) / sub).string());
  return lock;
}

void check_tail_members_in_one_process(const TrainConfig& cfg, int world, const std::string& source) {
  if (cfg.loop.hl_tail_members > 1 && world > 1)
    throw io::InputError(source + ": train.hl_tail_members = " + std::to_string(cfg.loop.hl_tail_members) +
                         " trains its tail members in one process, not over a group of ranks; train without "
                         "launch, or with train.hl_tail_members 1");
}
}  // namespace

std::vector<TrainSummary> train_tail_members(const std::string& run_dir, const std::atomic<bool>* stop,
                                             const std::function<void(int, const MetricsRow&)>& on_row) {
  const RunConfig run = read_run_config(run_dir);
  std::vector<TrainSummary> out;
  for (int m = 1; m < run.config.loop.hl_tail_members; ++m) {
    const std::string dir = (fs::path(run_dir) / "members" / std::to_string(m)).string();
    if (!fs::is_directory(dir))
      throw io::InputError(dir + ": missing, so tail member " + std::to_string(m) +
                           " was never forked (the run has not reached its tail, or the folder was removed); "
                           "continue the run with --resume " + run_dir + ", or train it again");
    auto member = Trainer::resume(dir);
    out.push_back(member->run(stop, -1, [&](const MetricsRow& r) {
      if (on_row) on_row(m, r);
    }));
    if (out.back().interrupted) break;
  }
  return out;
}

Trainer::Trainer(const TrainConfig& config, const std::string& run_dir, dist::Group* group)
    : s_(std::make_unique<State>()) {
  s_->cfg = config;
  s_->run_dir = run_dir;
  if (group != nullptr && group->size() > 1) {
    s_->group = group;
    s_->rank = group->rank();
    s_->world = group->size();
  }
  check_tail_members_in_one_process(config, s_->world, "the config");
  if (!s_->writes()) {  // another rank: the run folder is rank 0's
    s_->resolved_yaml = train_config_yaml(config);
    s_->hash = config_hash(s_->resolved_yaml);
    s_->build(true);
    s_->snapshot_pool();
    s_->load_opponent();
    return;
  }
  s_->lock = own_run_folder(run_dir);
  // Anything in the folder may be a run whose LATEST was lost: never write over it.
  if (const std::vector<std::string> data = io::run_data_in(run_dir); !data.empty()) {
    std::string names;
    for (const std::string& n : data) names += (names.empty() ? "" : ", ") + n;
    throw io::InputError(run_dir + " already holds a run (" + names + "): continue it with --resume " + run_dir +
                             ", move it aside with --overwrite, or choose another --run folder");
  }
  s_->resolved_yaml = train_config_yaml(config);
  s_->hash = config_hash(s_->resolved_yaml);
  s_->build(true);  // a config the run cannot be built from leaves the folder as it was
  // config.yaml first, then an empty LATEST (no checkpoint is durable yet): a run stopped anywhere
  // in between resumes afresh, while a missing LATEST beside checkpoint folders is a lost pointer.
  fs::create_directories(fs::path(run_dir) / "checkpoint");
  fs::create_directories(fs::path(run_dir) / "pool");
  io::write_file_atomic(run_dir + "/config.yaml", s_->resolved_yaml);
  io::write_file_atomic(run_dir + "/checkpoint/LATEST", "");
  // The untrained policy is the first pool snapshot, so pool matches exist from the start.
  s_->snapshot_pool();
  s_->load_opponent();
}

namespace {
// Rank 0's (or the single process's) reading of a run folder to resume: its config, and whether
// it has a checkpoint. A run killed before its first checkpoint has none and starts afresh.
RunConfig read_run_to_resume(const std::string& run_dir, bool* fresh) {
  if (!fs::is_directory(run_dir))
    throw io::InputError(run_dir + ": no such run folder to resume (a run stopped before it made its folder has "
                                   "nothing to resume: start it with f16race train --config CONFIG --run " + run_dir + ")");
  if (io::run_data_in(run_dir).empty())
    throw io::InputError(run_dir + ": holds no run yet (stopped before its config was written): start it with "
                                   "f16race train --config CONFIG --run " + run_dir);
  RunConfig run = read_run_config(run_dir);
  *fresh = false;
  if (!latest_checkpoint_name(run_dir).empty()) return run;
  // An empty LATEST, as a new run writes it: no checkpoint is durable yet (a folder beside it is
  // one whose LATEST was never written), so the run starts afresh.
  if (fs::exists(fs::path(run_dir) / "checkpoint" / "LATEST")) {
    *fresh = true;
    return run;
  }
  // No LATEST at all: lost, unless no checkpoint folder exists (a run from before the empty
  // LATEST, stopped before its first checkpoint). Folders beside a lost LATEST are refused,
  // named, and kept.
  std::string folders;
  std::error_code ec;
  for (const auto& entry : fs::directory_iterator(fs::path(run_dir) / "checkpoint", ec))
    if (entry.is_directory(ec)) folders += (folders.empty() ? "" : ", ") + entry.path().filename().string();
  if (folders.empty()) {
    *fresh = true;
    return run;
  }
  throw io::InputError(run_dir + ": no checkpoint to resume from (checkpoint/LATEST missing or empty) beside "
                       "checkpoint folder(s) " + folders + ": write the name of the one to resume into " + run_dir +
                       "/checkpoint/LATEST, or start afresh with --overwrite (the old run is kept aside)");
}
}  // namespace

std::unique_ptr<Trainer> Trainer::resume(const std::string& run_dir, dist::Group* group) {
  auto st = std::make_unique<State>();
  if (group != nullptr && group->size() > 1) {
    st->group = group;
    st->rank = group->rank();
    st->world = group->size();
  }
  RunConfig run;
  bool fresh = false;
  if (st->group == nullptr) {
    if (fs::is_directory(run_dir)) st->lock = own_run_folder(run_dir);
    run = read_run_to_resume(run_dir, &fresh);
  } else {
    // Rank 0 reads the run's config and sends it: the other ranks may be on hosts without the
    // folder. A problem on rank 0 is every rank's one line.
    std::string problem;
    if (st->writes()) {
      try {
        if (fs::is_directory(run_dir)) st->lock = own_run_folder(run_dir);
        run = read_run_to_resume(run_dir, &fresh);
      } catch (const std::exception& e) {
        problem = e.what();
      }
    }
    group->broadcast_bytes(problem);
    if (!problem.empty()) throw io::InputError(problem);
    std::string yaml = run.yaml, fresh_flag = fresh ? "1" : "0";
    group->broadcast_bytes(yaml);
    group->broadcast_bytes(fresh_flag);
    fresh = fresh_flag == "1";
    if (!st->writes()) {
      run.yaml = yaml;
      const std::string source = run_dir + "/config.yaml (from rank 0)";
      run.config = read_train_config(io::parse_yaml_text(run.yaml, source), source, ConfigOrigin::kRunFolder);
      run.hash = config_hash(run.yaml);
    }
  }
  check_tail_members_in_one_process(run.config, st->world, run_dir + "/config.yaml");
  st->cfg = run.config;
  st->run_dir = run_dir;
  st->resolved_yaml = std::move(run.yaml);
  st->hash = run.hash;
  if (fresh) {
    // Nothing durable yet: what the killed start left (a first pool snapshot, metrics rows) goes,
    // and the run begins again from its config, as `train --run` would have.
    if (st->writes()) st->clear_for_fresh_start();
    st->build(true);
    st->snapshot_pool();
    st->load_opponent();
  } else {
    st->build(false);
    st->load_checkpoint();
  }
  return std::unique_ptr<Trainer>(new Trainer(std::move(st)));
}

void Trainer::State::remove_uncommitted_checkpoints() const {
  const std::string latest = latest_checkpoint_name(run_dir);
  std::error_code ec;
  std::vector<fs::path> doomed;
  for (const auto& entry : fs::directory_iterator(fs::path(run_dir) / "checkpoint", ec))
    if (entry.is_directory(ec) && entry.path().filename() != latest) doomed.push_back(entry.path());
  for (const fs::path& p : doomed) fs::remove_all(p, ec);
}

void Trainer::State::clear_for_fresh_start() {
  for (const auto& entry : fs::directory_iterator(run_dir)) {
    const std::string name = entry.path().filename().string();
    if (name != ".lock" && name != "config.yaml") fs::remove_all(entry.path());
  }
  fs::create_directories(fs::path(run_dir) / "checkpoint");
  fs::create_directories(fs::path(run_dir) / "pool");
  io::write_file_atomic(run_dir + "/checkpoint/LATEST", "");
}

const TrainConfig& Trainer::config() const { return s_->cfg; }
std::int64_t Trainer::updates() const { return s_->ppo_updates + s_->es_updates; }
std::vector<float> Trainer::ll_parameters() const { return flat_parameters(*s_->ppo->net()); }
std::vector<float> Trainer::hl_parameters() const { return flat_parameters(*s_->es->critic()); }

void Trainer::State::build(bool fresh) {
  // Network initialisation draws from torch's global generator: seed it, once, here.
  torch::manual_seed(cfg.seed);
  pool = SnapshotPool(run_dir, cfg.pool.max_snapshots, writes());
  n_env_global = cfg.race.n_env;
  race::RaceConfig slice = cfg.race;
  if (world > 1) {
    if (cfg.race.n_env % world != 0)
      throw io::InputError("race.n_env = " + std::to_string(cfg.race.n_env) + " does not split evenly over " +
                           std::to_string(world) + " ranks: make it a multiple of " + std::to_string(world) +
                           " (each rank steps race.n_env / ranks envs)");
    slice.n_env = cfg.race.n_env / world;
  }
  // Global env ids: a rank's races are those envs of the group's batch (RaceEnv's first_env_id).
  env = std::make_unique<race::RaceEnv>(slice, rank * slice.n_env);
  n_env = env->n_env();
  n_agent = env->n_agent();
  ts = cfg.race.team_size;
  dims = obs_dims(*env);
  resolve_hl_scales(&cfg);
  cfg.ll.net.dims = dims;
  cfg.hl.dims = dims;
  // Planned PPO updates for the learning-rate schedule: the LL share of the step budget.
  const double ll_share = static_cast<double>(cfg.loop.ll_phase_updates) /
                          (cfg.loop.ll_phase_updates + cfg.loop.hl_phase_updates * cfg.hl.n_steps_per_update *
                                                           std::max(1.0, cfg.race.dt_hl_s / cfg.race.dt_ll_s) /
                                                           static_cast<double>(cfg.ll.n_steps));
  const double ll_steps = (1.0 - cfg.loop.hl_tail_share) * static_cast<double>(cfg.loop.total_env_steps);
  cfg.ll.total_updates =
      std::max<std::int64_t>(1, static_cast<std::int64_t>(ll_share * ll_steps / (cfg.ll.n_steps * n_env_global)) + 1);
  ppo = std::make_unique<agents::PpoAgent>(cfg.ll);
  es = std::make_unique<agents::EsAgent>(cfg.hl);
  opp_ppo = std::make_unique<agents::PpoAgent>(cfg.ll);
  opp_es = std::make_unique<agents::EsAgent>(cfg.hl);
  buffer = std::make_unique<agents::RolloutBuffer>(cfg.ll.n_steps, static_cast<std::int64_t>(n_env) * ts, dims,
                                                   race::kActionDim);
  // Each rank its own streams (rank 0's are a single process's): actions, matchups.
  gen = models::make_generator(cfg.seed * 7919 + 3 + static_cast<std::uint64_t>(rank) * 1000003);
  stream = RandomStream(cfg.seed, 0xC0FFEE + static_cast<std::uint64_t>(rank));
  if (group != nullptr) {
    agents::Replicas replicas;
    dist::Group* g = group;
    replicas.sum_floats = [g](float* v, std::int64_t n) { g->allreduce_sum(v, static_cast<std::size_t>(n)); };
    replicas.sum_doubles = [g](double* v, std::int64_t n) { g->allreduce_sum(v, static_cast<std::size_t>(n)); };
    replicas.gather = [g](const std::vector<double>& v) { return g->allgather(v); };
    ppo->set_replicas(replicas);
    es->set_replicas(replicas);
  }
  side.assign(n_env, 0);
  vs_pool.assign(n_env, 0);
  ll_rows = PolicyRows(2, n_env * n_agent);
  hl_rows = PolicyRows(2, n_env * n_agent);
  ll_ret.assign(static_cast<std::size_t>(n_env) * ts, 0.0);
  hl_ret.assign(static_cast<std::size_t>(n_env) * ts, 0.0);
  open.open.assign(n_env, 0);
  open.obs = HlObs{torch::zeros({n_env, ts, dims.d_ego}), torch::zeros({n_env, ts, 3}),
                   torch::zeros({n_env, ts, dims.n_other, dims.d_ado}), torch::zeros({n_env, ts, dims.n_other}, torch::kBool),
                   torch::zeros({n_env, ts, dims.d_task})};
  open.actions = torch::zeros({n_env, ts, 3}, torch::kInt64);
  open.reward = torch::zeros({n_env, ts});
  open.active = torch::zeros({n_env, ts}, torch::kBool);
  if (fresh && !cfg.loop.ll_from.empty()) load_frozen_low_level();
  if (fresh && (cfg.loop.ll_pilot == LowLevelPilot::kAutopilot || !cfg.loop.ll_from.empty())) phase = 1;
  if (fresh)
    for (int e = 0; e < n_env; ++e) draw_matchup(e);
}

void Trainer::State::load_frozen_low_level() {
  const std::string& from = cfg.loop.ll_from;
  const std::string name = latest_checkpoint_name(from);
  if (name.empty())
    throw io::InputError(from + ": train.ll_from names no trained run (no checkpoint/LATEST there): give a run "
                         "folder written by f16race train");
  const std::string path = from + "/checkpoint/" + name + "/ll.pt";
  const auto shapes = [this] {  // a load replaces tensors whole: a different network would just take their place
    std::vector<std::vector<std::int64_t>> out;
    for (const auto& p : ppo->net()->named_parameters()) out.push_back(p.value().sizes().vec());
    return out;
  };
  const auto before = shapes();
  bool fits = true;
  try {
    ppo->load(path);  // the networks, the observation statistics and the (unused) optimiser state
  } catch (const c10::Error&) {
    fits = false;
  }
  if (!fits || shapes() != before)
    throw io::InputError(path + ": train.ll_from's low level does not fit this config (observation sizes or the "
                         "ll: network differ): use the race: and ll: sections of " + from + "/config.yaml");
}

Matchup draw_matchup(RandomStream& stream, const PoolConfig& pool, bool pool_available, bool in_tail) {
  Matchup m;
  // Both numbers are always drawn, so the stream advances the same way whatever the settings.
  const double u_side = stream.uniform(), u_pool = stream.uniform();
  m.learner_side = pool.randomize_sides && u_side < 0.5 ? 1 : 0;
  // u_pool below p_center: the center-line control; above it, self-play or pool in the odds
  // p_self_play gives (outside the tail, p_center 0: the paper's draws).
  const double p_center = in_tail ? pool.p_center_tail : 0.0;
  m.vs_center = u_pool < p_center;
  m.vs_pool = !m.vs_center && pool_available && u_pool >= p_center + (1.0 - p_center) * pool.p_self_play;
  return m;
}

std::size_t draw_pool_entry(RandomStream& stream, std::size_t n) {
  return std::min(n - 1, static_cast<std::size_t>(stream.uniform() * static_cast<double>(n)));
}

void Trainer::State::draw_matchup(int e) {
  // The tail's races are those that start after the low level's last update (the step count
  // crosses the switch inside an update): its last update keeps the bilevel part's matchups.
  const Matchup m = train::draw_matchup(stream, cfg.pool, opponent >= 0, in_frozen_tail());
  side[e] = m.learner_side;
  vs_pool[e] = m.vs_center ? kVsCenter : (m.vs_pool ? kVsPool : kVsSelf);
}

torch::Tensor Trainer::State::learner_index() const {
  auto idx = torch::empty({static_cast<std::int64_t>(n_env) * ts}, torch::kInt64);
  auto* p = idx.data_ptr<std::int64_t>();
  for (int e = 0; e < n_env; ++e)
    for (int j = 0; j < ts; ++j) p[e * ts + j] = learner_agent(e, j);
  return idx;
}

void Trainer::State::close_open(int e, bool done, const HlObs& next_rows, const torch::Tensor& next_active) {
  if (!open.open[e]) return;
  done_obs.push_back(HlObs{open.obs.ego[e].clone(), open.obs.prev_action[e].clone(), open.obs.ado[e].clone(),
                           open.obs.ado_alive[e].clone(), open.obs.task[e].clone()});
  done_next.push_back(next_rows);
  done_actions.push_back(open.actions[e].clone());
  done_reward.push_back(open.reward[e].clone());
  done_flag.push_back(torch::tensor(done));
  done_active.push_back(open.active[e].clone());
  done_next_active.push_back(next_active);
  open.open[e] = 0;
}

void Trainer::State::hl_decisions() {
  const std::uint8_t* due = env->hl_due();
  bool any = false;
  for (int e = 0; e < n_env; ++e) any = any || due[e];
  if (!any) return;
  const HlObs obs = hl_view(false);
  const bool learn = phase == 1;
  const auto t_act = Clock::now();
  // Each critic decides for the aircraft it flies in the envs that are due, nothing else; the
  // other rows keep the middle bin, which set_hl_actions ignores outside due envs.
  hl_rows.assign(owners(due, /*high_level=*/true));
  torch::Tensor bins =
      torch::full({static_cast<std::int64_t>(n_env) * n_agent, race::kHlDims}, cfg.race.hl_center_bin(), torch::kInt64);
  auto* b = bins.data_ptr<std::int64_t>();
  for (int p = 0; p < 2; ++p) {
    const torch::Tensor& rows = hl_rows.rows(p);
    if (rows.numel() == 0) continue;
    agents::EsAgent& critic = p == 0 ? *es : *opp_es;
    const double eps = p == 0 ? cfg.hl.epsilon : cfg.loop.hl_epsilon_eval;
    scatter_rows(rows, critic.act(obs, rows, eps, gen).bins, b);
    work.hl_forward_rows += rows.numel();
    work.hl_forward_alive += models::count_alive(obs.ado_alive, rows);
    work.hl_forward_calls += 1;
  }
  timing.inference += since(t_act);
  const auto learner = learner_index();
  // Distance left to the old goals: how well the low level reached them.
  for (int e = 0; e < n_env; ++e) {
    if (!due[e] || env->race_time_s(e) <= 0.0) continue;
    for (int j = 0; j < ts; ++j) {
      const int i = learner_agent(e, j);
      if (!env->alive(i)) continue;
      sum_goal += env->goal_distance_ft(i);
      n_goal += 1;
    }
  }
  if (learn) {
    for (int e = 0; e < n_env; ++e) {
      if (!due[e]) continue;
      // The env's learner aircraft; index_rows gathers into fresh tensors, which the closed
      // transition keeps (nothing writes them afterwards).
      const auto idx = learner.slice(0, static_cast<std::int64_t>(e) * ts, static_cast<std::int64_t>(e + 1) * ts);
      const auto alive = hl_members(e);
      const HlObs next = models::index_rows(obs, idx);
      close_open(e, false, next, alive);
      open.obs.ego[e].copy_(next.ego);
      open.obs.prev_action[e].copy_(next.prev_action);
      open.obs.ado[e].copy_(next.ado);
      open.obs.ado_alive[e].copy_(next.ado_alive);
      open.obs.task[e].copy_(next.task);
      open.actions[e].copy_(bins.index_select(0, idx));
      open.reward[e].zero_();
      open.active[e].copy_(alive);
      open.open[e] = 1;
    }
  }
  env->set_hl_actions(bins.data_ptr<std::int64_t>());
}

void Trainer::State::ll_step(bool learn) {
  // Inference mode, not only no-grad: no version counters or autograd metadata on the many small
  // tensors of a step. What outlives the step is copied into tensors made outside it (the buffers).
  c10::InferenceMode inference;
  hl_decisions();
  const auto t_act = Clock::now();
  torch::Tensor actions = torch::empty({static_cast<std::int64_t>(n_env) * n_agent, race::kActionDim});
  agents::PpoAction act;
  if (cfg.loop.ll_pilot == LowLevelPilot::kAutopilot) {
    // Every aircraft, of both teams (a pool snapshot of this run flies the autopilot too).
    race::autopilot_actions(*env, goal_lane_autopilot(cfg), actions.data_ptr<float>());
  } else {
    const LlObs obs = ll_view(false);
    // Each policy acts only on the aircraft it flies (the pool snapshot on the other team of pool
    // envs, the learner on the rest); the learner's normaliser sees the rows it flies.
    ll_rows.assign(owners());
    const torch::Tensor& mine = ll_rows.rows(0);
    act = ll_rows.owns_all(0) ? ppo->act(obs, gen, /*update_stats=*/learn) : ppo->act(obs, mine, gen, learn);
    scatter_rows(mine, act.action, actions.data_ptr<float>());
    if (ll_rows.rows(1).numel() > 0)
      scatter_rows(ll_rows.rows(1), opp_ppo->act(obs, ll_rows.rows(1), gen, false).action, actions.data_ptr<float>());
    work.ll_forward_rows += act.action.size(0) + ll_rows.rows(1).numel();
    work.ll_forward_alive += models::count_alive(obs.ado_alive, ll_rows.owns_all(0) ? torch::Tensor() : mine) +
                            (ll_rows.rows(1).numel() > 0 ? models::count_alive(obs.ado_alive, ll_rows.rows(1)) : 0);
    work.ll_forward_calls += ll_rows.rows(1).numel() > 0 ? 2 : 1;
  }
  timing.inference += since(t_act);
  const auto learner = learner_index();  // before the step: sides change at resets
  // Samples of the learner team, taken before the env overwrites its buffers (act.obs may view
  // them), gathered straight into the buffer's next slot: aircraft k's row in act's outputs.
  if (learn) {
    auto pos = torch::empty_like(learner);
    const std::int64_t* li = learner.data_ptr<std::int64_t>();
    std::int64_t* pi = pos.data_ptr<std::int64_t>();
    for (std::int64_t k = 0; k < learner.numel(); ++k) pi[k] = ll_rows.position(static_cast<int>(li[k]));
    buffer->stage_picked(act.obs, act.action, act.log_prob, act.value, pos);
  }
  {  // airspeed of the learner's aircraft still racing, before the step (a finished race resets)
    const std::int64_t* li = learner.data_ptr<std::int64_t>();
    const double* vt = env->sim().state(dynamics::kVt);
    for (std::int64_t k = 0; k < learner.numel(); ++k)
      if (env->alive(static_cast<int>(li[k]))) sum_vt += vt[li[k]], n_vt += 1;
  }
  const auto t_env = Clock::now();
  env->step(actions.data_ptr<float>());
  timing.env += since(t_env);
  env_steps += n_env;  // a group sums its ranks' steps after each update (Trainer::run)
  rank_env_steps += n_env;

  // Per-sample bookkeeping through raw pointers: one torch op per element would cost more
  // than the simulator.
  const std::int64_t nl = static_cast<std::int64_t>(n_env) * ts;
  auto reward = torch::empty({nl});
  auto terminated = torch::empty({nl}, torch::kBool), truncated = torch::empty({nl}, torch::kBool);
  auto valid = torch::empty({nl}, torch::kBool);
  float* rw = reward.data_ptr<float>();
  bool* te = terminated.data_ptr<bool>();
  bool* tr = truncated.data_ptr<bool>();
  bool* va = valid.data_ptr<bool>();
  const std::int64_t* li = learner.data_ptr<std::int64_t>();
  float* open_reward = open.reward.data_ptr<float>();
  bool any_trunc = false;
  for (int e = 0; e < n_env; ++e) {
    for (int j = 0; j < ts; ++j) {
      const std::int64_t k = e * ts + j;
      const int i = static_cast<int>(li[k]);
      rw[k] = env->ll_reward()[i];
      te[k] = env->terminated()[i] != 0;
      tr[k] = env->truncated()[i] != 0;
      va[k] = env->acted()[i] != 0;
      any_trunc = any_trunc || env->truncated()[i];
      if (env->acted()[i]) ll_ret[k] += env->ll_reward()[i];
      // The HL reward runs to the race's end, also for an aircraft already taken out.
      hl_ret[k] += env->hl_reward()[i];
      if (phase == 1 && open.open[e]) open_reward[k] += static_cast<float>(cfg.hl.reward_scale * env->hl_reward()[i]);
      if (env->step_cause()[i] != race::kCauseNone) term[env->step_cause()[i]] += 1;
      if (env->terminated()[i] || env->truncated()[i]) {
        sum_ll_ret += ll_ret[k];
        n_ret += 1;
        ll_ret[k] = 0.0;
      }
      if (env->env_done()[e]) {
        sum_hl_ret += hl_ret[k];
        n_hl_ret += 1;
        hl_ret[k] = 0.0;
      }
    }
  }
  torch::Tensor bootstrap;
  if (learn && any_trunc) bootstrap = ppo->value(models::index_rows(ll_view(true), learner));
  if (learn) {
    buffer->commit(reward, terminated, truncated, bootstrap, valid);
  }
  // Races that ended: results, closing HL transitions, a fresh matchup for the next race.
  const std::uint8_t* done = env->env_done();
  for (int e = 0; e < n_env; ++e) {
    if (!done[e]) continue;
    races += 1;
    const int winner = env->race_winner()[e];
    wins += winner < 0 ? 0.5 : (winner == side[e] ? 1.0 : 0.0);
    finishes += env->race_end()[e] == race::RaceEnv::kEndFinishLine;
    if (phase == 1 && open.open[e]) {
      // The race really ends at the time limit too (time left is observed): terminal, unless
      // the config reports it as a truncation.
      const bool truncation = env->race_end()[e] == race::RaceEnv::kEndTimeLimit && !cfg.race.time_limit_terminal;
      const auto idx = learner.slice(0, static_cast<std::int64_t>(e) * ts, static_cast<std::int64_t>(e + 1) * ts);
      // Fresh tensors (index_rows gathers), kept by the closed transition as they are.
      const HlObs next = models::index_rows(hl_view(truncation), idx);
      // Terminal: no next state counts. Truncated: as at a decision, from the final state.
      const auto alive = truncation ? hl_members(e, true) : torch::zeros({ts}, torch::kBool);
      close_open(e, !truncation, next, alive);
    }
    draw_matchup(e);
  }
}

void Trainer::State::ppo_update() {
  const auto t = Clock::now();
  const LlObs last = models::index_rows(ll_view(false), learner_index());
  buffer->finish(ppo->value(last), cfg.ll.gamma, cfg.ll.gae_lambda);
  last_ppo = ppo->update(*buffer);
  timing.ppo_chunk_wait += last_ppo.chunk_wait_s;
  work.ll_forward_rows += static_cast<std::int64_t>(n_env) * ts;  // the bootstrap values above
  work.ll_forward_alive += models::count_alive(last.ado_alive);
  work.ll_forward_calls += 1;
  work.ll_train_rows += last_ppo.train_rows;
  work.ll_train_alive += last_ppo.train_alive;
  work.ll_train_calls += last_ppo.train_passes;
  work.ll_train_steps += last_ppo.grad_steps;
  buffer->clear();
  ++ppo_updates;
  timing.ppo += since(t);
}

void Trainer::State::es_update() {
  const auto t_start = Clock::now();
  auto stack_obs = [](const std::vector<HlObs>& v) {
    std::vector<torch::Tensor> a, b, c, d, e;
    for (const HlObs& o : v) {
      a.push_back(o.ego);
      b.push_back(o.prev_action);
      c.push_back(o.ado);
      d.push_back(o.ado_alive);
      e.push_back(o.task);
    }
    return HlObs{torch::stack(a), torch::stack(b), torch::stack(c), torch::stack(d), torch::stack(e)};
  };
  agents::EsBatch batch;
  if (done_obs.empty()) {
    // A rank of a group can close no transition before the group has its batch; it still takes
    // part in every gradient step, with none of the rows.
    const auto none = [](const torch::Tensor& t) { return t.slice(0, 0, 0).clone(); };
    batch.obs = HlObs{none(open.obs.ego), none(open.obs.prev_action), none(open.obs.ado), none(open.obs.ado_alive),
                      none(open.obs.task)};
    batch.next_obs = batch.obs;
    batch.actions = none(open.actions);
    batch.reward = none(open.reward);
    batch.done = torch::zeros({0}, torch::kBool);
    batch.active = none(open.active);
    batch.next_active = none(open.active);
  } else {
    batch.obs = stack_obs(done_obs);
    batch.next_obs = stack_obs(done_next);
    batch.actions = torch::stack(done_actions);
    batch.reward = torch::stack(done_reward);
    batch.done = torch::stack(done_flag);
    batch.active = torch::stack(done_active);
    batch.next_active = torch::stack(done_next_active);
  }
  batch.next_epsilon = cfg.hl.epsilon;
  last_es = es->update(batch);
  timing.es_chunk_wait += last_es.chunk_wait_s;
  hl_grad_steps += last_es.grad_steps;
  work.hl_forward_rows += last_es.forward_rows;
  work.hl_forward_alive += last_es.forward_alive;
  work.hl_train_alive += last_es.train_alive;
  work.hl_forward_calls += 2;
  work.hl_train_rows += last_es.train_rows;
  work.hl_train_calls += last_es.train_passes;
  work.hl_train_steps += last_es.grad_steps;
  done_obs.clear();
  done_next.clear();
  done_actions.clear();
  done_reward.clear();
  done_flag.clear();
  done_active.clear();
  done_next_active.clear();
  ++es_updates;
  timing.es += since(t_start);
}

void Trainer::State::group_sum(std::vector<double>& v) const {
  if (group != nullptr) group->allreduce_sum(v);
}
void Trainer::State::group_sum(std::vector<std::int64_t>& v) const {
  if (group != nullptr) group->allreduce_sum(v);
}

MetricsRow Trainer::State::make_row(const char* phase_name) {
  if (group != nullptr) {
    // The group's row: every rank's races and returns.
    std::vector<double> acc{sum_ll_ret, sum_hl_ret, n_ret, n_hl_ret, sum_goal, n_goal, sum_vt, n_vt, races, wins, finishes};
    acc.insert(acc.end(), std::begin(term), std::end(term));
    group_sum(acc);
    std::size_t k = 0;
    for (double* x : {&sum_ll_ret, &sum_hl_ret, &n_ret, &n_hl_ret, &sum_goal, &n_goal, &sum_vt, &n_vt, &races, &wins, &finishes})
      *x = acc[k++];
    for (double& t : term) t = acc[k++];
  }
  MetricsRow r;
  r.update = ppo_updates + es_updates;
  r.phase = phase_name;
  r.env_steps = env_steps;
  r.wall_s = wall();
  const double dt = std::max(r.wall_s - wall_at_row, 1e-9);
  r.samples_per_s = static_cast<double>(env_steps - steps_at_row) * n_agent / dt;
  r.ll_return = n_ret > 0 ? sum_ll_ret / n_ret : std::nan("");
  r.hl_return = n_hl_ret > 0 ? sum_hl_ret / n_hl_ret : std::nan("");
  r.goal_dist_ft = n_goal > 0 ? sum_goal / n_goal : std::nan("");
  r.airspeed_ftps = n_vt > 0 ? sum_vt / n_vt : std::nan("");
  r.races = races;
  r.winrate = races > 0 ? wins / races : std::nan("");
  r.finish_rate = races > 0 ? finishes / races : std::nan("");
  for (int k = 1; k < race::kNumCauses; ++k) r.term[k] = races > 0 ? term[k] / races : std::nan("");
  r.policy_loss = last_ppo.policy_loss;
  r.value_loss = last_ppo.value_loss;
  r.entropy = last_ppo.entropy;
  r.approx_kl = last_ppo.approx_kl;
  r.lr = last_ppo.learning_rate;
  r.es_loss = last_es.loss;
  r.q_mean = last_es.q_mean;
  r.epsilon = cfg.hl.epsilon;
  r.hl_grad_steps = hl_grad_steps;
  if (es_updates > 0) {
    r.es_loss_heldout = last_es.loss_before;
    r.es_end_atom_share = last_es.end_atom_share;
    r.es_huber_share = last_es.huber_share;
    r.q_spread = last_es.q_spread;
    r.greedy_entropy = last_es.greedy_entropy;
    r.off_center_share = last_es.off_center_share;
    r.middle_share = last_es.middle_share;
  }
  sum_ll_ret = sum_hl_ret = n_ret = n_hl_ret = sum_goal = n_goal = sum_vt = n_vt = races = wins = finishes = 0;
  std::fill(std::begin(term), std::end(term), 0.0);
  steps_at_row = env_steps;
  wall_at_row = r.wall_s;
  return r;
}

void Trainer::State::write_row(const MetricsRow& r) {
  if (!writes()) return;
  // Appended line by line: a crash loses at most the row being written, and resume drops rows
  // past the checkpoint it continues from.
  const std::string path = run_dir + "/metrics.csv";
  io::append_file(path, (fs::exists(path) ? std::string() : metrics_header_line() + "\n") + metrics_csv_line(r));
}

void Trainer::State::snapshot_pool() {
  pool.add(env_steps, opponent, [&](const std::string& dir) {
    ppo->save(dir + "/ll.pt");
    es->save(dir + "/hl.pt");
  });
}

void Trainer::State::load_opponent() {
  if (pool.empty()) {
    opponent = -1;
    return;
  }
  std::vector<std::int64_t> pick{static_cast<std::int64_t>(draw_pool_entry(stream, pool.steps().size()))};
  if (group != nullptr) {  // rank 0's draw for the group (every rank draws: streams advance alike)
    if (!writes()) pick[0] = 0;
    group_sum(pick);
  }
  opponent = pool.steps()[static_cast<std::size_t>(pick[0])];
  load_pool_snapshot();
}

void Trainer::State::load_pool_snapshot() {
  const fs::path dir = pool.folder(opponent);
  if (group == nullptr) {
    opp_ppo->load((dir / "ll.pt").string());
    opp_es->load((dir / "hl.pt").string());
    return;
  }
  // Rank 0 holds the pool; the others get the snapshot's bytes.
  std::string ll, hl;
  if (writes()) ll = read_text((dir / "ll.pt").string()), hl = read_text((dir / "hl.pt").string());
  group->broadcast_bytes(ll);
  group->broadcast_bytes(hl);
  opp_ppo->load_bytes(ll);
  opp_es->load_bytes(hl);
}

namespace {
// A rank's trainer state in a checkpoint folder: rank 0's is a single process's file.
std::string trainer_file(int rank) { return rank == 0 ? "trainer.pt" : "trainer_rank" + std::to_string(rank) + ".pt"; }

std::uint64_t fnv1a(const torch::nn::Module& m, std::uint64_t h) {
  for (const auto& t : m.parameters()) {
    const auto c = t.detach().contiguous();
    const auto* p = static_cast<const unsigned char*>(c.data_ptr());
    for (std::size_t i = 0; i < static_cast<std::size_t>(c.nbytes()); ++i) h = (h ^ p[i]) * 1099511628211ULL;
  }
  for (const auto& t : m.buffers()) {
    const auto c = t.detach().contiguous();
    const auto* p = static_cast<const unsigned char*>(c.data_ptr());
    for (std::size_t i = 0; i < static_cast<std::size_t>(c.nbytes()); ++i) h = (h ^ p[i]) * 1099511628211ULL;
  }
  return h;
}
}  // namespace

void Trainer::State::check_replicas_agree() {
  std::uint64_t h = 1469598103934665603ULL;
  h = fnv1a(*ppo->net(), h);
  h = fnv1a(*ppo->normalizer(), h);
  h = fnv1a(*es->critic(), h);
  h = fnv1a(*es->normalizer(), h);
  // Two exact halves in doubles.
  const std::vector<double> all = group->allgather({static_cast<double>(h >> 32), static_cast<double>(h & 0xFFFFFFFFULL)});
  for (int r = 1; r < world; ++r)
    if (all[2 * r] != all[0] || all[2 * r + 1] != all[1])
      throw std::runtime_error("rank " + std::to_string(r) + "'s networks differ from rank 0's at update " +
                               std::to_string(ppo_updates + es_updates) +
                               ": the replicas diverged (a bug: please report it); the last checkpoint is intact");
}

void Trainer::State::save_checkpoint(bool last) {
  const std::string name = step_name(env_steps) + "_u" + std::to_string(ppo_updates + es_updates);
  const fs::path dir = fs::path(run_dir) / "checkpoint" / name;
  // Every rank's trainer state as bytes; in a group they go to rank 0, which writes the folder.
  std::vector<std::string> states(1);
  {
    CheckpointWriter w;
    double wall_s = wall();
    std::uint64_t stream_state = stream.state();
    visit_checkpoint(w, wall_s, stream_state);
    w.a.write("generator", gen.get_state());
    if (world > 1) {  // ll.pt and hl.pt hold rank 0's minibatch order
      w.a.write("ppo_minibatch_generator", ppo->minibatch_generator().get_state());
      w.a.write("es_minibatch_generator", es->minibatch_generator().get_state());
    }
    std::ostringstream bytes;
    w.a.save_to(bytes);
    states[0] = bytes.str();
  }
  if (group != nullptr) {
    check_replicas_agree();
    states = group->allgather_bytes(states[0]);
    if (!writes()) {
      pool.release_retired(opponent);
      return;
    }
  }
  // The run's last figure is drawn on the curves thread beside the last checkpoint's writes; run()
  // waits for it after this returns, timed apart as TimeBreakdown::run_end (one draw path; the
  // overlap saves little: 32-env bench train on the Intel VM, gnuplot 0.09-0.15 s, the files 6-7
  // ms). metrics.csv holds the last row.
  const auto now = std::chrono::steady_clock::now();
  if (last) redraw_curves(now);
  const std::string previous = latest_checkpoint_name(run_dir);
  // A checkpoint that cannot be completed (full disk) is removed whole; LATEST still names the
  // previous one, which stays intact.
  try {
    fs::create_directories(dir);
    ppo->save((dir / "ll.pt").string());
    es->save((dir / "hl.pt").string());
    for (int r = 0; r < world; ++r) io::write_file_atomic((dir / trainer_file(r)).string(), states[static_cast<std::size_t>(r)]);
    std::ostringstream meta;
    meta << "format: " << kCheckpointFormat << "\nconfig_hash: " << hash << "\nenv_steps: " << env_steps
         << "\nupdates: " << ppo_updates + es_updates << "\n";
    if (world > 1) meta << "world_size: " << world << "\n";
    io::write_file_atomic((dir / "meta.yaml").string(), meta.str());
    // The pointer flips only once the folder is complete; then older checkpoints go.
    io::write_file_atomic(run_dir + "/checkpoint/LATEST", name);
  } catch (...) {
    std::error_code ec;
    fs::remove_all(dir, ec);
    throw;
  }
  if (!previous.empty() && previous != name) fs::remove_all(fs::path(run_dir) / "checkpoint" / previous);
  // Only now may the pool's retired snapshots go: the checkpoint that named them is replaced.
  pool.release_retired(opponent);
  // The learning-curve figure follows the checkpoints, at most every kCurvesEvery (and at the
  // last): a gnuplot draw takes ~0.07 s, and with a checkpoint every ~2.5 s (default config, 2
  // threads) the draws were ~3 % of the run (bench train, 150 updates: I/O 0.79-0.86 s -> 0.26-0.28
  // s of ~20 s). Without gnuplot only its data and script. A figure that cannot be drawn never
  // stops training: the reason goes to the final summary. Draws before the last run beside
  // training (io::BackgroundCurves; bench train, 32 envs: I/O 0.23-0.25 s of ~6 s with gnuplot,
  // 0.03 s without); one still under way skips a draw; run() waits for the last (started above).
  constexpr auto kCurvesEvery = std::chrono::seconds(30);
  if (last) return;
  if (curves_drawn_at && now - *curves_drawn_at < kCurvesEvery) return;
  if (curves.busy()) return;
  redraw_curves(now);
}

std::string latest_checkpoint_name(const std::string& run_dir) {
  std::ifstream f(run_dir + "/checkpoint/LATEST");
  std::string name;
  f >> name;
  return name;
}

std::string checkpoint_error_reason(const std::exception& e) {
  std::string what = e.what();
  if (const auto nl = what.find('\n'); nl != std::string::npos) what.resize(nl);
  if (what.size() > 160) what.resize(160);
  return what;
}

std::int64_t check_checkpoint_meta(const std::string& checkpoint_dir, std::uint64_t expected_config_hash,
                                   CheckpointUse use) {
  const YAML::Node meta = YAML::LoadFile(checkpoint_dir + "/meta.yaml");
  const int format = meta["format"].as<int>();
  const int oldest = use == CheckpointUse::policy ? kOldestPolicyFormat : kCheckpointFormat;
  if (format < oldest || format > kCheckpointFormat)
    throw std::runtime_error("checkpoint format " + meta["format"].as<std::string>() + ", this build reads " +
                             (oldest == kCheckpointFormat ? "" : std::to_string(oldest) + " to ") +
                             std::to_string(kCheckpointFormat) +
                             (use == CheckpointUse::resume && format < oldest && format >= kOldestPolicyFormat
                                  ? " to resume (its policy can still be raced, replayed and exported)"
                                  : ""));
  if (meta["config_hash"].as<std::uint64_t>() != expected_config_hash)
    throw std::runtime_error("it was written with a different config.yaml (hash mismatch); restore that file");
  return meta["env_steps"].as<std::int64_t>();
}

void Trainer::State::load_checkpoint() {
  // Rank 0 (or the single process) reads the files; in a group it sends every rank its part and
  // a problem found on any rank is every rank's one line.
  std::string problem, ll_bytes, hl_bytes;
  std::vector<std::string> states(static_cast<std::size_t>(world));
  fs::path dir, file;  // the file being read, for the error message
  if (writes()) {
    try {
      const std::string name = latest_checkpoint_name(run_dir);
      if (name.empty())
        throw io::InputError(run_dir + ": no checkpoint to resume from (checkpoint/LATEST missing or empty)");
      dir = fs::path(run_dir) / "checkpoint" / name;
      file = dir / "meta.yaml";
      int written_by = 1;
      try {
        check_checkpoint_meta(dir.string(), hash);
        const YAML::Node ws = YAML::LoadFile(file.string())["world_size"];
        written_by = ws ? ws.as<int>() : 1;
        if (written_by == world) {
          file = dir / "ll.pt";
          ll_bytes = read_text(file.string());
          file = dir / "hl.pt";
          hl_bytes = read_text(file.string());
          for (int r = 0; r < world; ++r) {
            file = dir / trainer_file(r);
            states[static_cast<std::size_t>(r)] = read_text(file.string());
          }
        }
      } catch (const std::exception& e) {
        throw io::InputError(file.string() + ": cannot resume from this checkpoint (" + checkpoint_error_reason(e) +
                             "); the file is corrupt, truncated or from another build: restore it or train again");
      }
      if (written_by != world)
        throw io::InputError(
            file.string() + ": this checkpoint was written by " +
            (written_by == 1 ? std::string("one process; resume it with one process (no WORLD_SIZE, no launch)")
                             : "a group of " + std::to_string(written_by) +
                                   " ranks, each holding its envs' states; resume it with f16race launch --nproc " +
                                   std::to_string(written_by) + " -- train --resume " + run_dir));
    } catch (const std::exception& e) {
      problem = e.what();
    }
  }
  std::string mine = states[0];
  if (group != nullptr) {
    group->broadcast_bytes(problem);
    if (problem.empty()) {
      group->broadcast_bytes(ll_bytes);
      group->broadcast_bytes(hl_bytes);
      for (int r = 0; r < world; ++r) {
        std::string bytes = states[static_cast<std::size_t>(r)];
        group->broadcast_bytes(bytes);
        if (r == rank) mine = std::move(bytes);
      }
    }
  }
  if (!problem.empty()) throw io::InputError(problem);
  // Parse on every rank; any rank's failure stops them all with its line.
  std::string what_failed;
  const std::string where = dir.empty() ? run_dir + "/checkpoint (rank 0's)" : dir.string();
  std::string part = "ll.pt";
  try {
    ppo->load_bytes(ll_bytes);
    part = "hl.pt";
    es->load_bytes(hl_bytes);
    part = trainer_file(rank);
    CheckpointReader r;
    r.a.load_from(mine.data(), mine.size());
    std::uint64_t stream_state = 0;
    visit_checkpoint(r, wall_offset, stream_state);
    stream.set_state(stream_state);
    gen.set_state(r.get("generator"));
    if (world > 1) {
      ppo->minibatch_generator().set_state(r.get("ppo_minibatch_generator"));
      es->minibatch_generator().set_state(r.get("es_minibatch_generator"));
    }
  } catch (const std::exception& e) {
    what_failed = where + "/" + part + ": cannot resume from this checkpoint (" + checkpoint_error_reason(e) +
                  "); the file is corrupt, truncated or from another build: restore it or train again";
  }
  if (group != nullptr)
    for (const std::string& p : group->allgather_bytes(what_failed))
      if (!p.empty()) throw io::InputError(p);
  if (!what_failed.empty()) throw io::InputError(what_failed);
  t0 = std::chrono::steady_clock::now();
  wall_at_row = wall_offset;
  steps_at_row = env_steps;
  // Snapshots taken after this checkpoint (or retired by it) are taken again or dropped again, and
  // a checkpoint folder whose LATEST was never written is written again.
  pool.remove_unnamed(opponent);
  if (writes()) remove_uncommitted_checkpoints();
  if (opponent >= 0) {
    try {
      load_pool_snapshot();
    } catch (const io::InputError&) {
      throw;
    } catch (const dist::PeerLost&) {
      throw;
    } catch (const std::exception& e) {
      throw io::InputError(run_dir + "/pool/" + step_name(opponent) + ": cannot load the pool snapshot this checkpoint plays (" +
                           checkpoint_error_reason(e) + "); restore it or train again");
    }
  }
  if (writes()) truncate_metrics();
}

void Trainer::State::truncate_metrics() {
  // Rows written after this checkpoint go (the resumed run writes them again).
  const std::string mpath = run_dir + "/metrics.csv";
  if (!fs::exists(mpath)) return;
  io::write_file_atomic(mpath, metrics_kept_up_to(read_text(mpath), ppo_updates + es_updates, mpath));
}

TrainSummary Trainer::run(const std::atomic<bool>* stop, std::int64_t max_updates,
                          const std::function<void(const MetricsRow&)>& on_row) {
  State& s = *s_;
  TrainSummary summary;
  s.timing = TimeBreakdown{};
  const auto t_run = State::Clock::now();
  std::int64_t done_here = 0;
  // Each rank fills its own share of an ES batch (a group's ranks may step different numbers of
  // steps in an HL phase: no collective per step) and the group sums its steps after the update.
  const std::int64_t hl_batch = static_cast<std::int64_t>(s.n_env) * s.cfg.hl.n_steps_per_update;
  const double comm_at_start = s.group != nullptr ? s.group->collective_seconds() : 0.0;
  const std::int64_t rank_steps_at_start = s.rank_env_steps;
  while (s.env_steps < s.cfg.loop.total_env_steps) {
    if (max_updates >= 0 && done_here >= max_updates) break;
    if (s.has_tail_members() && !s.tail_started && s.in_frozen_tail()) s.start_tail();
    const bool ll_phase = s.phase == 0 || s.cfg.loop.hl_phase_updates == 0;
    const std::int64_t steps_before = s.env_steps;
    if (ll_phase) {
      for (std::int64_t k = 0; k < s.cfg.ll.n_steps; ++k) s.ll_step(true);
      s.ppo_update();
    } else {
      while (static_cast<std::int64_t>(s.done_obs.size()) < hl_batch) s.ll_step(false);
      s.es_update();
    }
    if (s.group != nullptr) {
      std::vector<std::int64_t> stepped{s.env_steps - steps_before};
      s.group_sum(stepped);
      s.env_steps = steps_before + stepped[0];
    }
    ++done_here;
    ++s.phase_updates;
    const auto t_io = State::Clock::now();
    const MetricsRow row = s.make_row(ll_phase ? "ll" : "hl");
    s.write_row(row);
    summary.rows.push_back(row);
    if (on_row) on_row(row);
    const std::int64_t upd = s.ppo_updates + s.es_updates;
    if (upd % s.cfg.pool.snapshot_every_updates == 0) s.snapshot_pool();
    s.timing.io += State::since(t_io);
    // Phase switch: the other level learns next; a new pool opponent for the new phase.
    const int phase_len = ll_phase ? s.cfg.loop.ll_phase_updates : s.cfg.loop.hl_phase_updates;
    // In the HL-only tail (train.hl_tail_share) an LL phase ends at once and never comes back.
    const bool hl_only =
        s.cfg.loop.ll_pilot == LowLevelPilot::kAutopilot || !s.cfg.loop.ll_from.empty() || s.in_hl_tail();
    if ((s.phase_updates >= phase_len || (hl_only && s.phase == 0)) && s.cfg.loop.hl_phase_updates > 0) {
      // With only the high level learning its phase repeats, each time against a newly drawn pool
      // opponent.
      s.phase = hl_only ? 1 : 1 - s.phase;
      s.phase_updates = 0;
      for (int e = 0; e < s.n_env; ++e) s.open.open[e] = 0;  // decisions of the old phase are not learned from
      s.load_opponent();
      for (int e = 0; e < s.n_env; ++e)
        if (s.opponent < 0 && s.vs_pool[e] == State::kVsPool) s.vs_pool[e] = State::kVsSelf;
    }
    std::vector<std::int64_t> stop_votes{stop != nullptr && stop->load() ? 1 : 0};
    s.group_sum(stop_votes);  // a stop seen by any rank stops the group after the same update
    const bool stopping = stop_votes[0] > 0;
    const bool last =
        stopping || s.env_steps >= s.cfg.loop.total_env_steps || (max_updates >= 0 && done_here >= max_updates);
    if (last || upd % s.cfg.loop.checkpoint_every_updates == 0) {
      const auto t_ck = State::Clock::now();
      s.save_checkpoint(last);
      s.timing.io += State::since(t_ck);
    }
    if (last) {  // the run's last figure, started by its last checkpoint: done before the run returns
      const auto t_end = State::Clock::now();
      s.collect_curves();
      s.timing.run_end += State::since(t_end);
    }
    if (stopping) {
      summary.interrupted = true;
      break;
    }
  }
  summary.updates = s.ppo_updates + s.es_updates;
  summary.env_steps = s.env_steps;
  summary.hl_grad_steps = s.hl_grad_steps;
  summary.curves_problem = s.curves_problem;
  summary.rank_env_steps = s.rank_env_steps - rank_steps_at_start;
  summary.communication_s = s.group != nullptr ? s.group->collective_seconds() - comm_at_start : 0.0;
  s.timing.total = State::since(t_run);
  s.timing.other = s.timing.total - s.timing.env - s.timing.inference - s.timing.ppo - s.timing.es - s.timing.io -
                   s.timing.run_end;
  summary.time = s.timing;
  summary.work = s.work;
  return summary;
}

}  // namespace f16race::train
