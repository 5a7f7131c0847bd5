#pragma once
// Tensors over a RaceEnv's observation buffers, without a copy: rows are aircraft in env-major
// order (N = n_env * n_agent). The views alias the env's memory, so they change when the env
// steps; clone() what must outlive the next step.
#include <torch/torch.h>

#include <cstdint>

#include "models/obs.hpp"
#include "race/race_env.hpp"

namespace f16race::train {

inline models::ObsDims obs_dims(const race::RaceEnv& env) {
  return models::ObsDims{race::kEgoDim, env.ado_dim(), env.task_dim(), env.n_agent() - 1, race::kActionDim, race::kGoalDim};
}
inline models::ObsDims obs_dims(const race::RaceConfig& rc) {
  return models::ObsDims{race::kEgoDim, race::ado_dim(rc), race::task_dim(rc), rc.n_agent() - 1, race::kActionDim, race::kGoalDim};
}

// final_obs: the observations saved when a race ended by the time limit (for bootstrapping).
inline models::LlObs ll_obs_view(const race::RaceEnv& env, bool final_obs = false) {
  const models::ObsDims d = obs_dims(env);
  const std::int64_t n = env.n_aircraft();
  auto f = [](const float* p) { return const_cast<float*>(p); };
  const auto* alive = final_obs ? env.final_ado_alive() : env.obs_ado_alive();
  return models::LlObs{torch::from_blob(f(final_obs ? env.final_ego() : env.obs_ego()), {n, d.d_ego}),
                       torch::from_blob(f(final_obs ? env.final_goal() : env.obs_goal()), {n, race::kGoalDim}),
                       torch::from_blob(f(final_obs ? env.final_ado() : env.obs_ado()), {n, d.n_other, d.d_ado}),
                       torch::from_blob(const_cast<std::uint8_t*>(alive), {n, d.n_other}, torch::kBool),
                       torch::from_blob(f(final_obs ? env.final_task() : env.obs_task()), {n, d.d_task})};
}

inline models::HlObs hl_obs_view(const race::RaceEnv& env, bool final_obs = false) {
  const models::LlObs l = ll_obs_view(env, final_obs);
  const float* pa = final_obs ? env.final_prev_action() : env.obs_prev_action();
  return models::HlObs{l.ego, torch::from_blob(const_cast<float*>(pa), {env.n_aircraft(), race::kActionDim}), l.ado,
                       l.ado_alive, l.task};
}

}  // namespace f16race::train
