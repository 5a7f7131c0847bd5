// The rollout: LL steps of every env under the learner and its opponents, HL decisions when
// they are due, and what the learners gather from them (PPO samples, HL transitions, metrics).
#include <torch/torch.h>

#include <cstdint>
#include <vector>

#include "race/race_env.hpp"
#include "train/run_policy.hpp"
#include "train/trainer_state.hpp"

namespace f16race::train {

using models::HlObs;
using models::LlObs;

torch::Tensor Trainer::State::hl_members(int e, bool at_race_end) const {
  auto m = torch::ones({ts}, torch::kBool);
  if (agents::es_is_team(cfg.hl.variant))
    for (int j = 0; j < ts; ++j) {
      const int i = learner_agent(e, j);
      m.data_ptr<bool>()[j] = at_race_end ? env->truncated()[i] != 0 : env->alive(i);
    }
  return m;
}

std::vector<int> Trainer::State::owners(const std::uint8_t* only, bool high_level) const {
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

torch::Tensor Trainer::State::ll_actions(bool learn, agents::PpoAction* act) {
  const auto t_act = Clock::now();
  torch::Tensor actions = torch::empty({static_cast<std::int64_t>(n_env) * n_agent, race::kActionDim});
  if (cfg.loop.ll_pilot == LowLevelPilot::kAutopilot) {
    // Every aircraft, of both teams (a pool snapshot of this run flies the autopilot too).
    race::autopilot_actions(*env, goal_lane_autopilot(cfg), actions.data_ptr<float>());
  } else {
    const LlObs obs = ll_view(false);
    // Each policy acts only on the aircraft it flies (the pool snapshot on the other team of pool
    // envs, the learner on the rest); the learner's normaliser sees the rows it flies.
    ll_rows.assign(owners());
    const torch::Tensor& mine = ll_rows.rows(0);
    *act = ll_rows.owns_all(0) ? ppo->act(obs, gen, /*update_stats=*/learn) : ppo->act(obs, mine, gen, learn);
    scatter_rows(mine, act->action, actions.data_ptr<float>());
    if (ll_rows.rows(1).numel() > 0)
      scatter_rows(ll_rows.rows(1), opp_ppo->act(obs, ll_rows.rows(1), gen, false).action, actions.data_ptr<float>());
    work.ll_forward_rows += act->action.size(0) + ll_rows.rows(1).numel();
    work.ll_forward_alive += models::count_alive(obs.ado_alive, ll_rows.owns_all(0) ? torch::Tensor() : mine) +
                            (ll_rows.rows(1).numel() > 0 ? models::count_alive(obs.ado_alive, ll_rows.rows(1)) : 0);
    work.ll_forward_calls += ll_rows.rows(1).numel() > 0 ? 2 : 1;
    // Every aircraft of a training race flies this run's low level (its own or a pool snapshot's).
    apply_ll_throttle(cfg, nullptr, actions.size(0), actions.data_ptr<float>());
  }
  timing.inference += since(t_act);
  return actions;
}

void Trainer::State::ll_step(bool learn) {
  // Inference mode, not only no-grad: no version counters or autograd metadata on the many small
  // tensors of a step. What outlives the step is copied into tensors made outside it (the buffers).
  c10::InferenceMode inference;
  hl_decisions();
  agents::PpoAction act;
  const torch::Tensor actions = ll_actions(learn, &act);
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
  record_step(learner, learn);
  end_races(learner);
}

void Trainer::State::record_step(const torch::Tensor& learner, bool learn) {
  // Per-sample bookkeeping through raw pointers: one torch op per element would cost more
  // than the simulator.
  const std::int64_t* li = learner.data_ptr<std::int64_t>();
  float* open_reward = open.reward.data_ptr<float>();
  for (int e = 0; e < n_env; ++e) {
    for (int j = 0; j < ts; ++j) {
      const std::int64_t k = e * ts + j;
      const int i = static_cast<int>(li[k]);
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
  if (learn) commit_samples(learner);
}

void Trainer::State::commit_samples(const torch::Tensor& learner) {
  const std::int64_t n = learner.numel();
  auto reward = torch::empty({n});
  auto terminated = torch::empty({n}, torch::kBool), truncated = torch::empty({n}, torch::kBool);
  auto valid = torch::empty({n}, torch::kBool);
  float* rw = reward.data_ptr<float>();
  bool* te = terminated.data_ptr<bool>();
  bool* tr = truncated.data_ptr<bool>();
  bool* va = valid.data_ptr<bool>();
  const std::int64_t* li = learner.data_ptr<std::int64_t>();
  bool any_trunc = false;
  for (std::int64_t k = 0; k < n; ++k) {
    const int i = static_cast<int>(li[k]);
    rw[k] = env->ll_reward()[i];
    te[k] = env->terminated()[i] != 0;
    tr[k] = env->truncated()[i] != 0;
    va[k] = env->acted()[i] != 0;
    any_trunc = any_trunc || env->truncated()[i];
  }
  torch::Tensor bootstrap;
  if (any_trunc) bootstrap = ppo->value(models::index_rows(ll_view(true), learner));
  buffer->commit(reward, terminated, truncated, bootstrap, valid);
}

void Trainer::State::end_races(const torch::Tensor& learner) {
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

}  // namespace f16race::train
