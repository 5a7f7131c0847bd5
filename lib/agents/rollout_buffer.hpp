#pragma once
// On-policy storage for PPO: n_steps x n_samples low-level transitions (one sample = one
// aircraft), and generalised advantage estimation that distinguishes termination (no
// bootstrap) from time-limit truncation (bootstrap from the value of the final observation).
//
// Step t stores the (normalised) observation o_t the action was taken in, the action, its log
// probability and value V(o_t) under the acting policy, and what the environment returned:
// reward r_t, terminated_t, truncated_t, and for truncated samples bootstrap_value_t = V(final
// observation of the ended episode). GAE then uses
//   next value  = 0 if terminated_t, bootstrap_value_t if truncated_t, V(o_{t+1}) otherwise
//                 (last_value for t = n_steps - 1),
//   delta_t     = r_t + gamma next value - V(o_t),
//   A_t         = delta_t + gamma lambda (1 - terminated_t - truncated_t) A_{t+1},
//   return_t    = A_t + V(o_t).
#include <torch/torch.h>

#include "models/obs.hpp"

namespace f16race::agents {

struct GaeResult {
  torch::Tensor advantages;  // [T, N]
  torch::Tensor returns;     // [T, N]
};

// rewards, values, bootstrap_values [T, N] float32; terminated, truncated [T, N] bool;
// last_value [N] = V(o_T).
GaeResult compute_gae(const torch::Tensor& rewards, const torch::Tensor& values, const torch::Tensor& terminated,
                      const torch::Tensor& truncated, const torch::Tensor& bootstrap_values,
                      const torch::Tensor& last_value, double gamma, double gae_lambda);

class RolloutBuffer {
 public:
  RolloutBuffer(int64_t n_steps, int64_t n_samples, const models::ObsDims& dims, int64_t action_dim = 3);

  // Stores step `size()`. obs: normalised observation fields with batch n_samples; action
  // [N, A]; log_prob, value, reward [N]; terminated, truncated [N] bool; bootstrap_value [N]
  // (read where truncated; may be undefined when nothing was truncated); valid [N] bool
  // (optional, default all): false for aircraft that did not act (dead), left out of the loss.
  void add(const models::LlObs& obs, const torch::Tensor& action, const torch::Tensor& log_prob,
           const torch::Tensor& value, const torch::Tensor& reward, const torch::Tensor& terminated,
           const torch::Tensor& truncated, const torch::Tensor& bootstrap_value,
           const torch::Tensor& valid = torch::Tensor());
  // add() in two parts, for samples that are rows of a wider acting batch: stage_picked() gathers
  // rows `rows` (int64 [N]) of obs, action, log_prob and value straight into the next step's slot
  // (before the env step overwrites what obs may view), commit() adds the step's other fields and
  // makes the slot part of the buffer. A slot staged but never committed is overwritten by the next.
  void stage_picked(const models::LlObs& obs, const torch::Tensor& action, const torch::Tensor& log_prob,
                    const torch::Tensor& value, const torch::Tensor& rows);
  void commit(const torch::Tensor& reward, const torch::Tensor& terminated, const torch::Tensor& truncated,
              const torch::Tensor& bootstrap_value, const torch::Tensor& valid = torch::Tensor());
  // Runs GAE once the buffer is full; last_value [N] = V(o_T), the value after the last step.
  void finish(const torch::Tensor& last_value, double gamma, double gae_lambda);
  void clear() { size_ = 0; finished_ = false; }

  int64_t size() const { return size_; }
  bool full() const { return size_ == n_steps_; }
  bool finished() const { return finished_; }
  int64_t n_steps() const { return n_steps_; }
  int64_t n_samples() const { return n_samples_; }

  // Storage, [n_steps, n_samples, ...] each (observation fields likewise).
  models::LlObs obs;
  torch::Tensor actions, log_probs, values, rewards, terminated, truncated, bootstrap_values, valid;
  torch::Tensor advantages, returns;  // filled by finish()

 private:
  // add()'s fields other than the policy's outputs: checked before anything is written, then written.
  void check_step_fields(const torch::Tensor& reward, const torch::Tensor& terminated, const torch::Tensor& truncated,
                         const torch::Tensor& bootstrap_value, const torch::Tensor& valid) const;
  void add_step_fields(const torch::Tensor& reward, const torch::Tensor& terminated, const torch::Tensor& truncated,
                       const torch::Tensor& bootstrap_value, const torch::Tensor& valid);
  int64_t n_steps_, n_samples_, action_dim_;
  models::ObsDims dims_;
  int64_t size_ = 0;
  bool staged_ = false;  // stage_picked() wrote the slot at size_
  bool finished_ = false;
};

}  // namespace f16race::agents
