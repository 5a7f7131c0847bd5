#pragma once
// High-level learner: Expected SARSA over 3 action dimensions x n_bins bins (paper III-C a),
// in four variants. Execution is decentralised: each aircraft acts epsilon-greedily on its own
// utilities, with one coin per action dimension: with probability epsilon that dimension's bin
// is uniform, otherwise greedy. (With one coin per aircraft a bin explored in one dimension is
// only ever seen with the other two random too; es_d3 stalled in every noise-free toy run that
// way, see docs/learning.md.) Training of es_d2 / es_d3 is centralised over a team.
//
//   es     per aircraft, one Q over the n_bins^3 joint actions; each aircraft its own TD error.
//   es_d1  per aircraft, Q(o, a) = mean_j Q^j(o, a^j); each aircraft its own TD error.
//   es_d2  per team, Q = 1/(3 n_a) sum_i sum_j Q^{i,j}(o^i, a^{i,j})  (paper Eq. 1); one TD
//          error per team, the reward is the team mean.
//   es_d3  per team, p = 1/(3 n_a) sum_i sum_j p^{i,j}(o^i, a^{i,j}) over K atoms (Eq. 2-3);
//          cross-entropy to the C51 projection of r + gamma z under the next-state mixture
//          (optionally plus a per-component term, EsConfig::component_ce_weight).
//
// Target: y = r + gamma (1 - done) E_{a' ~ eps-greedy}[Q_target(o', a')], where r is the HL
// reward accumulated over the HL interval and the eps-greedy policy and values both come from
// the target network. With pi_j = (1 - eps) onehot(greedy_j) + eps / n_bins per dimension:
//   joint:      sum_a pi_0(a_0) pi_1(a_1) pi_2(a_2) Q(a), greedy from the joint argmax
//   decoupled:  mean_j [(1 - eps) max_b Q^j(b) + eps mean_b Q^j(b)]
//   d3:         mean_{i,j} [(1 - eps) p^{i,j}(greedy_j) + eps mean_b p^{i,j}(b)]  (a mixture)
// Value variants use the Huber loss.
//
// n_ES,step (paper Table I: 10) is not defined in the paper. Reading used here: the number of
// high-level transitions each environment contributes to one ES update, i.e. the trainer
// collects n_steps_per_update HL decisions per env (from all teams) and then calls update()
// once on that batch (n_epochs passes of n_minibatches gradient steps), the HL analogue of
// n_PPO,step = 32 LL steps per env per PPO update.
#include <torch/torch.h>

#include <array>
#include <cmath>
#include <memory>
#include <string>
#include <utility>
#include <vector>

#include "agents/checkpoint_content.hpp"
#include "agents/c51.hpp"
#include "agents/eigen_mirror.hpp"
#include "agents/es_chunk_pass.hpp"
#include "agents/gradient_step.hpp"
#include "agents/replicas.hpp"
#include "models/hl_critic.hpp"
#include "models/kernels/attention_mlp_forward.hpp"
#include "models/obs.hpp"
#include "models/running_norm.hpp"

namespace f16race::agents {

enum class EsVariant { kEs, kEsD1, kEsD2, kEsD3 };

// ES+D3's loss: the cross-entropy of the team mixture against the projected C51 target (C51's
// reading of the paper's Eq. 3), or the paper's Eq. 5 read literally: Huber on the TD error of the
// mixture's expected value, the distribution shaped only through its mean.
enum class D3Loss { kCrossEntropy, kHuberMean };

// "es", "es_d1", "es_d2", "es_d3"; throws std::invalid_argument naming the bad value.
EsVariant parse_es_variant(const std::string& name);
const char* es_variant_name(EsVariant v);
inline bool es_is_team(EsVariant v) { return v == EsVariant::kEsD2 || v == EsVariant::kEsD3; }
inline bool es_is_decoupled(EsVariant v) { return v != EsVariant::kEs; }

struct EsConfig {
  EsVariant variant = EsVariant::kEsD3;
  models::ObsDims dims;  // from the environment
  int64_t d_model = 64;
  int64_t n_heads = 4;
  std::vector<int64_t> hidden{64, 64};
  int64_t n_bins = 7;     // paper Table I n_ES,bin
  int64_t n_atoms = 51;   // es_d3 only (C51)
  double v_min = -10.0;   // es_d3 atom support [v_min, v_max] (the trainer derives it, see
  double v_max = 10.0;    // train::resolve_hl_scales)
  // Factor on the HL reward summed over an interval, applied by the trainer (the agent sees the
  // scaled reward). The trainer's default is dt_ll / dt_hl: the interval's mean reward.
  double reward_scale = 1.0;
  double gamma = 0.99;    // per HL decision
  double epsilon = 0.1;   // paper Table I eps_ES: drawn per aircraft and goal axis
  int64_t n_steps_per_update = 10;  // n_ES,step: HL transitions per env per update (read by the trainer)
  int64_t target_update_interval = 10;  // updates between hard target-network syncs
  int64_t n_epochs = 1;       // passes over each batch
  int64_t n_minibatches = 1;  // gradient steps per pass (team samples split evenly)
  // A gradient step's teams in this many contiguous chunks whose gradients (each weighted by its
  // share of the step's valid units) run concurrently on the OpenMP threads and add up in chunk
  // order: the same step up to float summation order, the same bits at any thread count (exact
  // for the paper's loss; with component_ce_weight the component term is weighted so too). 1: one
  // pass, the arithmetic of a plain backward().
  int64_t minibatch_chunks = 1;
  double learning_rate = 3e-4;
  double adam_eps = 1e-5;
  double max_grad_norm = 10.0;
  double huber_delta = 1.0;
  // es_d3 only: adds this weight x the mean cross-entropy of each component p^{i,j}(a^{i,j}) to
  // the team target. 0 (default) is the paper's loss. A component's gradient under the mixture
  // loss alone scales with its share of the mixture's mass at the target atoms, so with
  // near-deterministic returns components of rarely taken bins can stop learning (measured on
  // the toy: 6 of 10 noise-free runs stalled; 0.1 fixed 6 of 6). See docs/learning.md.
  double component_ce_weight = 0.0;
  D3Loss d3_loss = D3Loss::kCrossEntropy;  // es_d3 only
  bool normalize_obs = true;
  double obs_clip = 10.0;
  uint64_t seed = 1;  // minibatch order
  // The decisions' action values (act, q_values): the critic on Eigen float kernels
  // (models/kernels/attention_mlp_forward.hpp, equal to HlCritic::forward to float rounding; the
  // decisions come a few at a time, where LibTorch's per-op cost is most of the price), or
  // LibTorch's ops (false). Not a config key: tests and benchmarks compare the two paths.
  bool eigen_inference = true;
  // ES+D2's and ES+D3's gradient steps: the critic's forward and backward on the fused pass
  // (agents/es_chunk_pass.hpp), or LibTorch's autograd (false: the oracle the tests hold it to).
  // The other variants always take autograd. Not a config key.
  bool fused_training = true;
};

models::HlCriticConfig es_critic_config(const EsConfig& cfg);
// Whether the gradient steps take the fused training pass: fused_training, and a team loss it
// serves (ES+D2; ES+D3's cross-entropy without the component term).
bool es_fused_training(const EsConfig& cfg);

struct EsAction {
  torch::Tensor bins;         // [B, 3] int64, the eps-greedy choice
  torch::Tensor greedy_bins;  // [B, 3] int64
  torch::Tensor q;            // decoupled [B, 3, n_bins]; es [B, n_bins^3]
};

// One batch of HL transitions grouped by team: T team samples of n_a aircraft.
struct EsBatch {
  models::HlObs obs;       // every field [T, n_a, ...] (raw, unnormalised)
  torch::Tensor actions;   // [T, n_a, 3] int64 bins taken
  torch::Tensor reward;    // [T, n_a] float32, HL reward accumulated over the interval, per aircraft
  models::HlObs next_obs;  // [T, n_a, ...] at the next HL decision (final obs on truncation)
  torch::Tensor done;      // [T] bool: episode terminated (not a time-limit truncation)
  torch::Tensor active;       // optional [T, n_a] bool: the aircraft took this decision (default all)
  torch::Tensor next_active;  // optional [T, n_a] bool: alive at the next decision (default all)
  double next_epsilon = 0.1;  // eps of the policy at the next decision
};

struct EsStats {
  double loss = 0.0;
  double q_mean = 0.0;       // mean predicted value of the taken actions
  double target_mean = 0.0;  // mean TD target (expected value of the target distribution for es_d3)
  double td_abs_mean = 0.0;
  double grad_norm = 0.0;    // before clipping, last gradient step
  int64_t update_index = 0;  // updates done, including this one
  int64_t grad_steps = 0;    // gradient steps of this update
  int64_t train_rows = 0;    // aircraft rows through forward+backward, summed over its steps
  int64_t train_passes = 0;  // forward+backward passes (a step's chunks with valid units)
  int64_t forward_rows = 0;  // aircraft rows through no-grad forwards (target, diagnostics)
  int64_t train_alive = 0;   // other aircraft alive in the train rows (bench train's floor)
  int64_t forward_alive = 0; // and in the forward rows
  double chunk_wait_s = 0.0; // the steps' wall time beyond an even split of their chunks over the threads (run_chunks)
  bool target_synced = false;
  // Diagnostics of the online critic on the batch before the update (rows that took the
  // decision). Does the high level choose anything, and do its targets fit its critic?
  double loss_before = 0.0;        // loss on the batch before any step of this update: new data, so held out
  double q_spread = 0.0;           // mean over rows (and dimensions) of max_b Q - min_b Q
  double greedy_entropy = 0.0;     // entropy of the greedy bins over the batch / log(n_bins), mean over dims
  double off_center_share = 0.0;   // rows whose greedy bins differ from the middle bin on some axis
  // Per axis of the goal frame (track: along, right, up; world: north, east, up), the share of
  // rows whose greedy bin is the middle one: does the high level ever choose the center lane?
  std::array<double, 3> middle_share{std::nan(""), std::nan(""), std::nan("")};
  double end_atom_share = std::nan("");  // es_d3: mean target mass on the two end atoms
  double huber_share = std::nan("");     // es, es_d1, es_d2: share of |TD error| > huber_delta
};

// Diagnostics of q (decoupled [N, 3, n_bins] or joint [N, n_bins^3]) over rows: fills q_spread,
// greedy_entropy, off_center_share and middle_share of `stats`.
void es_policy_diagnostics(const torch::Tensor& q, int64_t n_bins, EsStats* stats);

// --- pure pieces of the update, exposed for tests -------------------------------------------
// Expectation of q [N, n_bins^3] under the per-dimension eps-greedy policy of its joint argmax -> [N].
torch::Tensor egreedy_value_joint(const torch::Tensor& q, double eps);
// (1 - eps) max_b + eps mean_b per axis j: q [N, 3, n_bins] -> [N, 3].
torch::Tensor egreedy_value_per_axis(const torch::Tensor& q, double eps);
// Its mean over the axes: q [N, 3, n_bins] -> [N].
torch::Tensor egreedy_value_decoupled(const torch::Tensor& q, double eps);
// mean_j [(1 - eps) p_j(argmax_b q_j) + eps mean_b p_j(b)]: log_probs [N, 3, n_bins, K],
// q [N, 3, n_bins] -> [N, K] probabilities.
torch::Tensor egreedy_mixture_decoupled(const torch::Tensor& log_probs, const torch::Tensor& q, double eps);
// Joint index b_0 n_bins^2 + b_1 n_bins + b_2 of bins [..., 3] -> [...], and back.
torch::Tensor joint_index(const torch::Tensor& bins, int64_t n_bins);
torch::Tensor decode_joint_index(const torch::Tensor& index, int64_t n_bins);

struct EsTarget {
  // es, es_d1: [T, n_a]; es_d2: [T]; es_d3: [T] expected value of `dist`
  torch::Tensor value;
  torch::Tensor dist;   // es_d3: [T, K] projected target distribution
};

// Targets from the target network's output on the next observations (fields over T*n_a rows,
// aircraft-major within a team). reward [T, n_a]; done [T]; active, next_active [T, n_a] bool.
EsTarget es_target(EsVariant v, const models::HlOutput& next_out, const torch::Tensor& reward,
                   const torch::Tensor& done, const torch::Tensor& active, const torch::Tensor& next_active,
                   double next_epsilon, double gamma, const C51Support& support);

struct EsLoss {
  torch::Tensor loss;        // scalar
  torch::Tensor prediction;  // same shape as EsTarget::value
  torch::Tensor valid;       // bool, same shape: samples that count in the loss
};

// Loss of the online output (over T*n_a rows) for the taken actions [T, n_a, 3].
EsLoss es_loss(EsVariant v, const models::HlOutput& out, const torch::Tensor& actions, const torch::Tensor& active,
               const EsTarget& target, double huber_delta, const C51Support& support,
               double component_ce_weight = 0.0, D3Loss d3_loss = D3Loss::kCrossEntropy);

class EsAgent {
 public:
  explicit EsAgent(const EsConfig& cfg);
  // Decentralised eps-greedy action of each aircraft; obs fields have batch B. No gradients.
  EsAction act(const models::HlObs& obs, double epsilon, at::Generator& generator);
  // The same for the rows `rows` (int64 [R]) of obs, read in place: act(index_rows(obs, rows))
  // bit for bit (the Eigen path normalises the picked rows in the forward's blocks, without the
  // gathered copy).
  EsAction act(const models::HlObs& obs, const torch::Tensor& rows, double epsilon, at::Generator& generator);
  // act() in two halves: the critic's action values on `obs` (EsAction::q's shape; no gradients),
  // and the eps-greedy choice on given values of that shape (an ensemble's mean, or q_values').
  torch::Tensor q_values(const models::HlObs& obs);
  torch::Tensor q_values(const models::HlObs& obs, const torch::Tensor& rows);
  EsAction choose(const torch::Tensor& q, double epsilon, at::Generator& generator) const;
  // With replicas set (issue 18), every rank calls update() at the same point with its own batch
  // (T may differ, even be 0), and each gradient step is the step on the union of the ranks'
  // minibatches. The diagnostics of EsStats (loss_before, shares, spread) are this rank's.
  EsStats update(const EsBatch& batch);
  void set_replicas(const Replicas& replicas);
  void sync_target();
  // kPolicy: the online critic without the target network and the optimiser state (a shared
  // policy, which cannot resume training); its load sets the target to the critic.
  void save(const std::string& path, CheckpointContent content = CheckpointContent::kFull) const;
  void load(const std::string& path);
  void load_bytes(const std::string& bytes);  // a file's bytes, received instead of read
  CheckpointContent loaded_content() const { return loaded_content_; }

  const EsConfig& config() const { return cfg_; }
  models::HlCritic& critic() { return critic_; }
  models::HlCritic& target_critic() { return target_; }
  models::ObsNormalizer& normalizer() { return normalizer_; }
  torch::optim::Adam& optimizer() { return *optimizer_; }
  int64_t update_count() const { return update_count_; }
  // Minibatch order. A data-parallel replica's draws depend on its own batch sizes, so each rank
  // keeps its own state (the trainer's per-rank checkpoint part).
  at::Generator& minibatch_generator() { return generator_; }

 private:
  models::HlObs prepare(const models::HlObs& flat_obs, bool update_stats);
  // The no-grad forward of the online critic (or the target) on normalised rows, on its Eigen
  // mirror when there is one: acting, the update's target and its diagnostics all read it.
  models::HlOutput forward_no_grad(bool target, const models::HlObs& normalised);
  // update()'s parts (the gradient step itself: agents/gradient_step.hpp).
  struct UpdateData;
  void measure_before_steps(const models::HlObs& obs, const EsBatch& batch, const torch::Tensor& active,
                            const EsTarget& target, EsStats* stats);
  GradientStepResult minibatch_step(const UpdateData& d, const torch::Tensor& teams, EsStats* stats);
  void chunk_gradient(const UpdateData& d, const torch::Tensor& teams, bool weighted,
                      const std::vector<torch::Tensor>& params, ChunkGradient& k, EsChunkPass& pass);
  void load_archive(torch::serialize::InputArchive& root);
  EsConfig cfg_;
  Replicas replicas_;
  C51Support support_;
  models::HlCritic critic_{nullptr}, target_{nullptr};
  models::ObsNormalizer normalizer_{nullptr};
  std::unique_ptr<torch::optim::Adam> optimizer_;
  at::Generator generator_;
  int64_t update_count_ = 0;
  CheckpointContent loaded_content_ = CheckpointContent::kFull;
  // The online critic for q_values on Eigen kernels; it follows every write to the critic's
  // weights (an optimiser step, a load, a write through critic()).
  EigenMirror eigen_;
  EigenMirror target_eigen_;  // the same for the target network (it follows sync_target's copies)
  std::vector<float> norm_terms_;  // the raw-rows forward's float normalisation terms, reused
  std::vector<std::unique_ptr<EsChunkPass>> chunk_passes_;  // one per concurrent chunk (fused_training)
};

}  // namespace f16race::agents
