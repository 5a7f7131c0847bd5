#include "eval/tournament_games.hpp"

#include <torch/torch.h>

#include <algorithm>
#include <array>
#include <cstdint>
#include <string>

#include "dist/process_group.hpp"
#include "eval/tournament_journal.hpp"
#include "io/input_error.hpp"
#include "race/block_events.hpp"
#include "race/scripted_pilot.hpp"
#include "train/obs_views.hpp"
#include "train/policy_rows.hpp"
#include "train/run_policy.hpp"

namespace f16race::eval {

namespace {

using models::HlObs;
using models::LlObs;
using Lost = std::array<int, race::kNumCauses>;
using Choices = std::array<int, kChoiceFields>;

// This rank's envs [lo, hi) of the whole batch of n: every rank makes the same assignments in
// global env order, so the split changes no race.
struct EnvSplit {
  int n, lo, hi;
};

EnvSplit split_envs(const RaceGamesInputs& in) {
  const int n = static_cast<int>(
      std::min<std::size_t>(static_cast<std::size_t>(in.options->batch_envs), in.games->size()));
  const int world = in.group ? in.group->size() : 1, rank = in.group ? in.group->rank() : 0;
  if (n < world)
    throw io::InputError("tournament: " + std::to_string(n) + " races at once cannot be split over " +
                         std::to_string(world) + " ranks; give --batch (and races) of at least the number of ranks");
  return {n, static_cast<int>(static_cast<long long>(n) * rank / world),
          static_cast<int>(static_cast<long long>(n) * (rank + 1) / world)};
}

race::RaceConfig local_race(race::RaceConfig rc, const EnvSplit& s) {
  rc.n_env = s.hi - s.lo;
  return rc;
}

// One batch of envs for the whole tournament: an env whose race ends takes the next game at
// once, so no env idles until the slowest race of a batch is over. Each game's track and start
// come from its own stream, race r of every pairing on track r / 2 (both sides of each track
// flown, sides swapped), and its @random draws from the race's own: the same race whatever env
// slot it lands in, so pairings within a tournament and the same pairing in tournaments of other
// entries race the same tracks (common random numbers for paired comparisons).
class GameBatch {
 public:
  explicit GameBatch(const RaceGamesInputs& in);
  std::vector<RaceRecord> run();

 private:
  void assign(int eg);
  void choose_hl_bins();
  void count_choices();
  void act();
  void collect_ended(std::vector<RaceRecord>* out);
  void advance();
  RaceRecord record(int e) const;

  const RaceGamesInputs& in_;
  const std::vector<Game>& games_;
  const std::vector<Entry>& entries_;
  const int n_entries_;
  const EnvSplit split_;
  const race::RaceConfig rc_;  // this rank's envs
  const int ts_, n_agent_, nl_;
  at::Generator gen_;
  race::RaceEnv env_;
  race::BlockCounter blocks_;
  // The @random rule's draws: the stream of the env's current race, used only at its own HL decisions.
  std::vector<RandomStream> control_rng_;  // [nl]
  std::vector<long> env_game_;             // [n] game raced in each env of the whole batch, -1 idle
  std::vector<Lost> lost_blue_, lost_red_;  // [nl][cause]
  std::vector<Choices> choices_blue_, choices_red_;  // [nl][axis * 3 + below / middle / above]
  std::vector<int> owner_;                  // [nl * n_agent] entry flying this rank's aircraft i, -1 none
  std::size_t next_game_ = 0;
  // Aircraft rows per entry: every network acts only on the aircraft it flies.
  train::PolicyRows rows_, hl_rows_;
  std::vector<std::int64_t> bins_;  // [nl * n_agent * 3]
  std::vector<float> actions_;      // [nl * n_agent * 3]
  race::AutopilotPilotConfig autopilot_;
  long done_games_ = 0, reported_ = 0;
  int active_;
  std::vector<std::int64_t> ended_;  // [n] races that ended this step, over the whole batch
  std::vector<double> t_before_;     // [nl] each env's race time before the step
};

GameBatch::GameBatch(const RaceGamesInputs& in)
    : in_(in),
      games_(*in.games),
      entries_(*in.entries),
      n_entries_(static_cast<int>(in.entries->size())),
      split_(split_envs(in)),
      rc_(local_race(in.race, split_)),
      ts_(rc_.team_size),
      n_agent_(rc_.n_agent()),
      nl_(rc_.n_env),
      gen_(models::make_generator(in.options->seed * 31 + 7)),
      env_(rc_, split_.lo),
      blocks_(env_),
      control_rng_(nl_, control_stream(in.options->seed, 0)),
      env_game_(split_.n, -1),
      lost_blue_(nl_),
      lost_red_(nl_),
      choices_blue_(nl_),
      choices_red_(nl_),
      owner_(static_cast<std::size_t>(nl_) * n_agent_, -1),
      rows_(n_entries_, nl_ * n_agent_),
      hl_rows_(n_entries_, nl_ * n_agent_),
      bins_(static_cast<std::size_t>(nl_) * n_agent_ * 3, rc_.hl_center_bin()),
      actions_(static_cast<std::size_t>(nl_) * n_agent_ * 3, 0.0f),
      active_(split_.n),
      ended_(split_.n, 0),
      t_before_(nl_) {
  const TournamentOptions& o = *in.options;
  autopilot_.airspeed_ftps = o.autopilot_airspeed_ftps > 0.0 ? o.autopilot_airspeed_ftps : rc_.autopilot_airspeed();
  autopilot_.shift_up_frac = autopilot_shift_up(o, rc_);
  if (o.autopilot_on_line) autopilot_.lines = &env_.racing_lines();  // each race's, drawn at its start
  for (int e = 0; e < split_.n; ++e) assign(e);
  rows_.assign(owner_);
}

// Env eg of the whole batch takes the next game (or idles); this rank sets up its own envs only.
void GameBatch::assign(int eg) {
  env_game_[eg] = next_game_ < games_.size() ? static_cast<long>(next_game_++) : -1;
  if (eg < split_.lo || eg >= split_.hi) return;
  const int e = eg - split_.lo;
  lost_blue_[e].fill(0);
  lost_red_[e].fill(0);
  choices_blue_[e].fill(0);
  choices_red_[e].fill(0);
  const Game* g = env_game_[eg] >= 0 ? &games_[env_game_[eg]] : nullptr;
  for (int a = 0; a < n_agent_; ++a) owner_[e * n_agent_ + a] = g ? (a < ts_ ? g->blue : g->red) : -1;
  if (!g) return;
  env_.start_race(e, track_stream_id(g->race / 2));
  control_rng_[e] = control_stream(in_.options->seed, g->race);
}

// Every team's HL bins from its entry's rule: the run's HL policy on the rows it flies in the
// envs that are due, or, for a control entry, its fixed rule per team of a due env (drawn in env
// and team order, so independent of the thread count).
void GameBatch::choose_hl_bins() {
  const HlObs obs = train::hl_obs_view(env_);
  std::vector<int> hl_owner(owner_);
  for (std::size_t i = 0; i < hl_owner.size(); ++i) {
    const int e = static_cast<int>(i) / n_agent_;
    if (hl_owner[i] >= 0 && (!env_.hl_due()[e] || !hl_override_uses_policy(entries_[hl_owner[i]].hl) ||
                             is_autopilot(entries_[hl_owner[i]])))
      hl_owner[i] = -1;
  }
  hl_rows_.assign(hl_owner);
  for (int id = 0; id < n_entries_; ++id)
    train::policy_hl_bins((*in_.policies)[entries_[id].policy], obs, hl_rows_.rows(id), in_.options->epsilon, gen_,
                          bins_.data());
  for (int e = 0; e < nl_; ++e) {
    if (env_game_[split_.lo + e] < 0 || !env_.hl_due()[e]) continue;
    for (int team = 0; team < 2; ++team) {
      const Entry& en = entries_[owner_[e * n_agent_ + team * ts_]];
      // The autopilot has no high level: its goals stay on the center-line (reward only).
      if (is_control(en) || is_autopilot(en))
        fixed_hl_bins(is_autopilot(en) ? HlOverride::center : en.hl, rc_.hl_bins, ts_, control_rng_[e],
                      bins_.data() + static_cast<std::size_t>(e * n_agent_ + team * ts_) * race::kHlDims);
    }
  }
}

// The bins just chosen in the due envs, per team, living aircraft only.
void GameBatch::count_choices() {
  const int mid = rc_.hl_center_bin();
  for (int e = 0; e < nl_; ++e) {
    if (env_game_[split_.lo + e] < 0 || !env_.hl_due()[e]) continue;
    for (int a = 0; a < n_agent_; ++a) {
      const int i = e * n_agent_ + a;
      if (!env_.alive(i)) continue;
      Choices& c = a < ts_ ? choices_blue_[e] : choices_red_[e];
      for (int d = 0; d < race::kHlDims; ++d) {
        const std::int64_t b = bins_[static_cast<std::size_t>(i) * race::kHlDims + d];
        c[d * 3 + (b < mid ? 0 : b == mid ? 1 : 2)] += 1;
      }
    }
  }
}

// Every entry's low-level actions on the aircraft it flies.
void GameBatch::act() {
  const LlObs obs = train::ll_obs_view(env_);
  for (int id = 0; id < n_entries_; ++id) {
    const torch::Tensor& rows = rows_.rows(id);
    if (rows.numel() == 0) continue;
    if (is_autopilot(entries_[id]))
      race::autopilot_actions(env_, autopilot_, actions_.data(), rows.data_ptr<std::int64_t>(), rows.numel());
    else
      train::greedy_ll_actions((*in_.policies)[entries_[id].policy], env_, obs, rows, gen_, actions_.data());
  }
}

RaceRecord GameBatch::record(int e) const {
  const Game& g = games_[env_game_[split_.lo + e]];
  RaceRecord r;
  r.pair = g.pair;
  r.blue = g.blue;
  r.red = g.red;
  r.track_seed = rc_.seed;
  r.env = split_.lo + e;
  r.race = g.race;
  r.track = g.race / 2;
  const int w = env_.race_winner()[e];
  r.winner = w < 0 ? -1 : (w == 0 ? g.blue : g.red);
  r.end_reason = env_.race_end()[e];
  r.duration_s = t_before_[e] + rc_.dt_ll_s;
  r.blue_lost = lost_blue_[e];
  r.red_lost = lost_red_[e];
  r.blue_blocks = blocks_.race_blocks(e, 0);
  r.red_blocks = blocks_.race_blocks(e, 1);
  r.blue_choices = choices_blue_[e];
  r.red_choices = choices_red_[e];
  return r;
}

// After a step: each team's losses by cause, and a record of every race that ended in it.
void GameBatch::collect_ended(std::vector<RaceRecord>* out) {
  std::fill(ended_.begin(), ended_.end(), 0);
  for (int e = 0; e < nl_; ++e) {
    if (env_game_[split_.lo + e] < 0) continue;
    for (int a = 0; a < n_agent_; ++a)
      if (const int c = env_.step_cause()[e * n_agent_ + a]; c != race::kCauseNone)
        (a < ts_ ? lost_blue_[e] : lost_red_[e])[c] += 1;
    if (!env_.env_done()[e]) continue;
    out->push_back(record(e));
    ended_[split_.lo + e] = 1;
  }
}

// Every rank's ended envs take their next games, in global env order.
void GameBatch::advance() {
  if (in_.group) in_.group->allreduce_sum(ended_);
  bool changed = false;
  for (int eg = 0; eg < split_.n; ++eg) {
    if (ended_[eg] == 0) continue;
    ++done_games_;
    assign(eg);
    active_ -= env_game_[eg] < 0;
    changed = changed || (eg >= split_.lo && eg < split_.hi);
  }
  if (changed) rows_.assign(owner_);
  // Progress about every 1 % of the games.
  if (in_.progress && (done_games_ - reported_ >= std::max<long>(1, in_.total / 100) ||
                       (active_ == 0 && done_games_ != reported_))) {
    reported_ = done_games_;
    in_.progress(in_.done_before + done_games_, in_.total);
  }
}

std::vector<RaceRecord> GameBatch::run() {
  std::vector<RaceRecord> out, now;  // every race of this rank; those that ended this step
  while (active_ > 0) {
    bool due = false;
    for (int e = 0; e < nl_; ++e) due = due || (env_.hl_due()[e] && env_game_[split_.lo + e] >= 0);
    if (due) {
      choose_hl_bins();
      count_choices();
      env_.set_hl_actions(bins_.data());
    }
    act();
    for (int e = 0; e < nl_; ++e) t_before_[e] = env_.race_time_s(e);
    env_.step(actions_.data());
    blocks_.after_step(race::block_view(env_));
    now.clear();
    collect_ended(&now);
    if (in_.journal) in_.journal->append(now);
    out.insert(out.end(), now.begin(), now.end());
    advance();
  }
  return out;
}

}  // namespace

std::vector<RaceRecord> race_games(const RaceGamesInputs& in) {
  c10::InferenceMode inference;  // as the trainer's rollout: no autograd bookkeeping on any tensor of a race
  GameBatch batch(in);
  return batch.run();
}

}  // namespace f16race::eval
