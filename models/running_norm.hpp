#pragma once
// Running observation normalisation (as gym's NormalizeObservation / RunningMeanStd, which
// CleanRL's PPO uses): per-feature mean and variance merged batch by batch (Chan et al.),
// normalised value clamp((x - mean) / sqrt(var + eps), -clip, clip). The statistics are module
// buffers in float64, so they are saved and loaded with the model.
//
//   RunningNorm(dim):  update(x [N, dim]);  normalize(x [..., dim]) -> same shape, float32
//   ObsNormalizer:     one RunningNorm per observation field; the ado statistics are taken over
//                      alive rows only and dead rows normalise to 0.
#include <torch/torch.h>

#include <array>
#include <functional>
#include <vector>

#include "models/kernels/attention_mlp_forward.hpp"
#include "models/kernels/normalize_row.hpp"
#include "models/obs.hpp"

namespace f16race::models {

// Rows of x picked by an index instead of a gathered copy: logical row r is x's row
// index[r / group] * group + r % group (group: rows per indexed sample, e.g. the n_other ado rows).
// The statistics and outputs are those of the gathered rows, bit for bit.
struct RowPick {
  const int64_t* index = nullptr;  // [count]
  int64_t count = 0, group = 1;
  int64_t rows() const { return count * group; }
  int64_t at(int64_t r) const { return index[r / group] * group + r % group; }
};

class RunningNormImpl : public torch::nn::Module {
 public:
  explicit RunningNormImpl(int64_t dim, double clip = 10.0, double eps = 1e-8);
  void update(const torch::Tensor& x);
  torch::Tensor normalize(const torch::Tensor& x) const;
  // The same over the rows of x [N, dim] where keep [N] (bool) is true: statistics from those rows
  // only, and the other rows normalise to exact zeros (dead aircraft in o_ado).
  void update_rows(const torch::Tensor& x, const torch::Tensor& keep);
  torch::Tensor normalize_rows(const torch::Tensor& x, const torch::Tensor& keep) const;
  // update_rows in two halves, for replicas that pool their batches first: a batch's moments
  // appended to `out` as [n, mean (dim), m2 (dim)] (m2: summed squared deviations), and the merge
  // of such moments into the statistics (n = 0: nothing).
  void batch_moments(const torch::Tensor& x, const torch::Tensor& keep, std::vector<double>* out,
                     const RowPick* pick = nullptr) const;
  // With `pick`, over the picked rows of x (and of keep) only, the output [pick rows, dim].
  void update_picked(const torch::Tensor& x, const torch::Tensor& keep, const RowPick& pick);
  torch::Tensor normalize_picked(const torch::Tensor& x, const torch::Tensor& keep, const RowPick& pick) const;
  void merge_moments(const double* moments);
  int64_t dim() const { return dim_; }
  const torch::Tensor& mean() const { return mean_; }
  // The float32 terms normalize() applies: (x - mean) * inv_std, clamped to +-clip.
  torch::Tensor mean_f32() const { return mean_.to(torch::kFloat32); }
  // The same terms written into mean [dim] and inv_std [dim], as normalize() rounds them, for
  // kernels::normalize_row (which normalize() applies row by row).
  kernels::NormTerms float_terms(float* mean, float* inv_std) const;
  torch::Tensor inv_std_f32() const { return torch::rsqrt(var_ + eps_).to(torch::kFloat32); }
  double clip() const { return clip_; }
  const torch::Tensor& var() const { return var_; }
  double count() const { return count_.item<double>(); }

 private:
  torch::Tensor normalize_impl(const torch::Tensor& x, const torch::Tensor& keep, const RowPick* pick) const;
  int64_t dim_;
  double clip_, eps_;
  torch::Tensor mean_, var_, count_;
};
TORCH_MODULE(RunningNorm);

// Every replica's moments (the same length on each), concatenated in replica order; issue 18's
// data-parallel ranks set one so that their statistics absorb every rank's batches together.
using MomentsGather = std::function<std::vector<double>(const std::vector<double>&)>;

class ObsNormalizerImpl : public torch::nn::Module {
 public:
  explicit ObsNormalizerImpl(const ObsDims& dims, double clip = 10.0);
  // With a gather (data-parallel replicas), updates are held back: normalize(update_stats) adds
  // the batch's moments to a pending sum and the statistics stay as they are, until
  // sync_replicas() merges every replica's pending moments (one gather, merged in replica
  // order). Replicas so normalise alike at every step, and the statistics lag one rollout behind
  // a single process's. Without a gather (the default) a batch is absorbed at once.
  void set_moments_gather(MomentsGather gather);
  // Replicas: absorb every replica's pending batches (a collective: every replica calls it at the
  // same point). One process: nothing to do.
  void sync_replicas();
  // Normalised copy of `obs`; with update_stats the statistics first absorb this batch.
  HlObs normalize(const HlObs& obs, bool update_stats);
  LlObs normalize(const LlObs& obs, bool update_stats);
  // The same for the rows `rows` (int64 [R]) of obs, read in place: what normalize(index_rows(obs,
  // rows)) gives, without the gathered copy (the rollout's policies each fly a subset of rows).
  LlObs normalize(const LlObs& obs, const torch::Tensor& rows, bool update_stats);
  // normalize(update_stats)'s first half: the statistics absorb obs's rows `rows` (int64 [R]; all
  // rows when undefined), nothing normalised (AttentionMlpForward normalises in its blocks).
  void absorb(const LlObs& obs, const torch::Tensor& rows);
  // The rows `rows` (int64 [B], contiguous; undefined: all rows) of a raw observation, as
  // AttentionMlpForward reads them to normalise them in its blocks with these statistics (rounded
  // to float into *terms) into `out` (B rows, allocated by the caller). Every tensor must be
  // contiguous (checked) and, with *terms, outlive the forward. The one place both agents' raw
  // rollout forwards are set up (PpoAgent's actions, EsAgent's decisions).
  LlRawRows raw_rows(const LlObs& raw, const torch::Tensor& rows, const LlObs& out, std::vector<float>* terms) const;
  LlRawRows raw_rows(const HlObs& raw, const torch::Tensor& rows, const HlObs& out, std::vector<float>* terms) const;
  // Per field: ego, extra (prev_action for the HL, goal for the LL), ado, task.
  const RunningNorm& ego() const { return ego_; }
  const RunningNorm& extra() const { return extra_; }
  const RunningNorm& ado() const { return ado_norm_; }
  const RunningNorm& task() const { return task_; }

 private:
  torch::Tensor ado_(const torch::Tensor& ado, const torch::Tensor& alive, bool update_stats);
  // raw_rows over the five fields (ego, extra, ado, alive, task) of either level.
  LlRawRows raw_fields(const std::array<const torch::Tensor*, 5>& raw, const torch::Tensor& rows,
                       const std::array<const torch::Tensor*, 5>& out, std::vector<float>* terms) const;

  // A batch of the four fields into `pending_` (replicas).
  void hold_back(const torch::Tensor& ego, const torch::Tensor& extra, const torch::Tensor& ado,
                 const torch::Tensor& alive, const torch::Tensor& task);
  MomentsGather gather_;
  std::vector<double> pending_;  // the four fields' moments since the last sync, batch_moments' layout
  ObsDims dims_;
  RunningNorm ego_{nullptr}, extra_{nullptr}, ado_norm_{nullptr}, task_{nullptr};
};
TORCH_MODULE(ObsNormalizer);

}  // namespace f16race::models
