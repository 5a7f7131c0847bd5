// The learners' updates from what the rollout gathered: PPO on the low level's rollout buffer,
// Expected SARSA on the closed HL transitions.
#include <torch/torch.h>

#include <vector>

#include "train/trainer_state.hpp"

namespace f16race::train {

using models::HlObs;
using models::LlObs;

void Trainer::State::ppo_update() {
  const auto t = Clock::now();
  const LlObs last = models::index_rows(ll_view(false), learner_index());
  buffer->finish(ppo->value(last), cfg.ll.gamma, cfg.ll.gae_lambda);
  last_ppo = ppo->update(*buffer);
  timing.ppo_chunk_wait += last_ppo.chunk_wait_s;
  work.ll_forward_rows += last.ego.size(0);  // the bootstrap values above
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

}  // namespace f16race::train
