#pragma once
// Low-level learner: PPO with a clipped objective (paper Eq. 4), transcribed from CleanRL's
// ppo_continuous_action.py (Huang et al., https://github.com/vwxyzjn/cleanrl): per-minibatch
// advantage normalisation, clipped value loss, global gradient-norm clipping, Adam with eps
// 1e-5 and a learning rate annealed linearly to 0 over the planned number of updates, running
// observation normalisation. Decentralised: every aircraft is one sample.
//
// Trainer loop (per update):
//   for n_steps: a = act(raw_obs, gen)            // normalises (and updates the statistics)
//                env.step(a.action) -> r, terminated, truncated, final obs of ended episodes
//                bootstrap = value(final_obs)     // only needed where truncated
//                buffer.add(a.obs, a.action, a.log_prob, a.value, r, terminated, truncated, bootstrap,
//                           alive)          // dead aircraft are stored but left out of the update
//   buffer.finish(value(raw_obs_after_last_step), gamma, gae_lambda); update(buffer); buffer.clear()
#include <torch/torch.h>

#include <memory>
#include <string>

#include "agents/checkpoint_content.hpp"
#include "agents/eigen_mirror.hpp"
#include "agents/gradient_step.hpp"
#include "agents/ppo_chunk_pass.hpp"
#include "agents/replicas.hpp"
#include "agents/rollout_buffer.hpp"
#include "models/ll_actor_critic.hpp"
#include "models/obs.hpp"
#include "models/running_norm.hpp"

namespace f16race::agents {

struct PpoConfig {
  models::LlActorCriticConfig net;  // net.dims from the environment
  double gamma = 0.99;              // paper Table I
  double gae_lambda = 0.95;         // paper Table I
  int64_t n_steps = 32;             // n_PPO,step: steps per env (per aircraft) per update
  int64_t n_minibatches = 4;        // n_PPO,mini
  int64_t n_epochs = 4;             // n_PPO,epoch
  // A minibatch of more rows runs forward/backward in chunks of at most this many whose gradients
  // add up before its one optimiser step: the same update (up to float summation order), at the
  // per-sample cost of a cache-sized batch (bench nets, 2 threads: 6.1 us fwd+bwd at 2048 rows,
  // 11.7 us at 32768), and the chunks run concurrently on the OpenMP threads. 512 splits the
  // default config's ~920-row minibatches in two, so both cores work on every PPO step
  // (README, Performance). 0: one pass per minibatch.
  int64_t max_chunk_rows = 512;
  double clip_coef = 0.2;
  bool clip_value_loss = true;
  double vf_coef = 0.5;
  double ent_coef = 0.0;
  double max_grad_norm = 0.5;
  double learning_rate = 3e-4;
  double adam_eps = 1e-5;
  bool anneal_lr = true;
  int64_t total_updates = 0;  // planned updates; the lr reaches 0 after this many (needed if anneal_lr)
  bool normalize_advantages = true;
  bool normalize_obs = true;
  double obs_clip = 10.0;
  uint64_t seed = 1;  // minibatch order
  // No-grad forward passes of act() and value(): the same network on Eigen float kernels
  // (models/kernels/attention_mlp_forward.hpp, equal to LibTorch's to float rounding; faster at rollout
  // batch sizes, docs/performance.md), or LibTorch's ops (false). Not a config key: tests and
  // benchmarks compare the two paths. Training's pass: fused_training below.
  bool eigen_inference = true;
  // The update's forward and backward: the fused pass on plain buffers (agents/ppo_chunk_pass.hpp,
  // the same products and tanh as the rollouts'), or LibTorch's autograd (false: the oracle the
  // tests hold it to). Not a config key.
  bool fused_training = true;
};

struct PpoAction {
  torch::Tensor action;    // [B, A] sampled, unclipped
  torch::Tensor log_prob;  // [B]
  torch::Tensor value;     // [B]
  torch::Tensor mean;      // [B, A] deterministic action
  models::LlObs obs;       // the normalised observation (what the buffer stores)
};

struct PpoLossTerms {
  torch::Tensor total;          // policy - ent_coef entropy + vf_coef value
  torch::Tensor policy_loss;    // mean max(-A r, -A clip(r, 1 - c, 1 + c))
  torch::Tensor value_loss;     // 0.5 mean max((V - R)^2, (V_old + clip(V - V_old, -c, c) - R)^2)
  torch::Tensor entropy;        // mean
  torch::Tensor approx_kl;      // mean (r - 1) - log r  (no gradient)
  torch::Tensor clip_fraction;  // fraction with |r - 1| > c  (no gradient)
};

// One minibatch's loss; all inputs [M]. Advantages are normalised inside when
// cfg.normalize_advantages (with the unbiased std + 1e-8, as CleanRL).
PpoLossTerms ppo_loss(const torch::Tensor& new_log_prob, const torch::Tensor& old_log_prob,
                      const torch::Tensor& advantages, const torch::Tensor& new_value, const torch::Tensor& old_value,
                      const torch::Tensor& returns, const torch::Tensor& entropy, const PpoConfig& cfg);

struct PpoStats {
  double policy_loss = 0.0;  // means over all minibatch steps of the update
  double value_loss = 0.0;
  double entropy = 0.0;
  double approx_kl = 0.0;
  double clip_fraction = 0.0;
  double learning_rate = 0.0;  // used in this update
  double explained_variance = 0.0;
  int64_t update_index = 0;  // updates done, including this one
  int64_t grad_steps = 0;    // minibatch steps of this update
  int64_t train_rows = 0;    // samples through forward+backward, summed over its minibatches
  int64_t train_passes = 0;  // forward+backward passes (chunks of at most max_chunk_rows)
  int64_t train_alive = 0;   // other aircraft alive in those samples (bench train's floor)
  double chunk_wait_s = 0.0; // the steps' wall time beyond an even split of their chunks over the threads (run_chunks)
};

class PpoAgent {
 public:
  explicit PpoAgent(const PpoConfig& cfg);
  // Normalised observation (statistics updated first when update_stats and cfg.normalize_obs).
  models::LlObs normalize(const models::LlObs& raw, bool update_stats);
  // Samples a ~ N(mean, exp(log_std)) with `generator`. No gradients.
  PpoAction act(const models::LlObs& raw, at::Generator& generator, bool update_stats = true);
  // The same for the rows `rows` (int64 [R]) of raw, read in place: act(index_rows(raw, rows)) bit
  // for bit, without the gathered copy.
  PpoAction act(const models::LlObs& raw, const torch::Tensor& rows, at::Generator& generator,
                bool update_stats = true);
  // V(raw obs) with the current statistics, not updating them: last_value and bootstrap values.
  torch::Tensor value(const models::LlObs& raw);
  // With replicas set (issue 18), every rank calls update() at the same point with its own
  // buffer, and each minibatch step is the step on the union of the ranks' minibatches.
  PpoStats update(const RolloutBuffer& buffer);
  // Learn as one of several data-parallel replicas (agents/replicas.hpp); the statistics of
  // act(update_stats) then absorb every replica's rows.
  void set_replicas(const Replicas& replicas);
  // kPolicy: without the optimiser state (a shared policy, which cannot resume training).
  void save(const std::string& path, CheckpointContent content = CheckpointContent::kFull) const;
  void load(const std::string& path);
  // The same from a file's bytes (a rank that received them instead of reading the file).
  void load_bytes(const std::string& bytes);
  // What the last load read: a kPolicy file leaves the optimiser fresh.
  CheckpointContent loaded_content() const { return loaded_content_; }

  double learning_rate_for_update(int64_t update_index) const;
  const PpoConfig& config() const { return cfg_; }
  models::LlActorCritic& net() { return net_; }
  models::ObsNormalizer& normalizer() { return normalizer_; }
  torch::optim::Adam& optimizer() { return *optimizer_; }
  int64_t update_count() const { return update_count_; }
  // Minibatch order. A data-parallel replica's draws depend on its own batch sizes, so each rank
  // keeps its own state (the trainer's per-rank checkpoint part).
  at::Generator& minibatch_generator() { return generator_; }

 private:
  // mean [B, A] and value [B] of a normalised observation, by the configured inference path.
  std::pair<torch::Tensor, torch::Tensor> infer(const models::LlObs& obs);
  // The Eigen forward into mean [B, A] and value [B]; with `draw`, the actions sampled too.
  void infer_into(const models::LlObs& obs, torch::Tensor& mean, torch::Tensor& value, const models::GaussianDraw* draw);
  // The same from raw observations (rows `rows` of them, all when undefined), normalised with the
  // current statistics into `out` (allocated, [B, ...]) in the forward's blocks.
  void infer_raw_into(const models::LlObs& raw, const torch::Tensor& rows, const models::LlObs& out,
                      torch::Tensor& mean, torch::Tensor& value, const models::GaussianDraw* draw);
  // update()'s parts (the gradient step itself: agents/gradient_step.hpp).
  struct UpdateData;
  UpdateData update_data(const RolloutBuffer& buffer) const;
  bool minibatch_step(const UpdateData& d, const torch::Tensor& mb, const double* moments, PpoStats* stats);
  void load_archive(torch::serialize::InputArchive& root);
  PpoConfig cfg_;
  Replicas replicas_;
  models::LlActorCritic net_{nullptr};
  models::ObsNormalizer normalizer_{nullptr};
  std::unique_ptr<torch::optim::Adam> optimizer_;
  at::Generator generator_;
  int64_t update_count_ = 0;
  CheckpointContent loaded_content_ = CheckpointContent::kFull;
  EigenMirror eigen_;  // the network on Eigen kernels for the rollout (cfg_.eigen_inference)
  std::vector<float> norm_terms_;  // infer_raw_into's float normalisation terms, reused
  std::vector<std::unique_ptr<PpoChunkPass>> chunk_passes_;  // one per concurrent chunk (fused_training)
};

}  // namespace f16race::agents
