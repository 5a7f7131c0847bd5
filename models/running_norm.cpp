#include "models/running_norm.hpp"

#include <algorithm>
#include <array>
#include <cmath>
#include <vector>

#include <omp.h>

#include "models/kernels/normalize_row.hpp"

namespace f16race::models {

RunningNormImpl::RunningNormImpl(int64_t dim, double clip, double eps) : dim_(dim), clip_(clip), eps_(eps) {
  TORCH_CHECK(dim > 0, "RunningNorm: dim must be > 0");
  // gym's initial state: mean 0, var 1, count 1e-4 (a tiny prior that avoids dividing by 0).
  mean_ = register_buffer("mean", torch::zeros({dim}, torch::kFloat64));
  var_ = register_buffer("var", torch::ones({dim}, torch::kFloat64));
  count_ = register_buffer("count", torch::full({}, 1e-4, torch::kFloat64));
}

// Statistics and normalisation in plain loops over the rows: a rollout step normalises ~100-300
// rows of four fields, where a dozen LibTorch ops per field cost more than the arithmetic.
// Big batches (256+ envs) share them over the OpenMP threads without changing a bit: the
// normalisation row by row, the moments column by column (each column still summed over its rows
// in order, whichever thread owns it).
namespace {
constexpr int64_t kParallelElements = 1 << 15;  // below this the threads' start-up costs more

// Runs f(c0, c1) over a partition of the columns [0, d) into the threads' contiguous shares.
template <class F>
void over_column_shares(int64_t rows, int64_t d, const F& f) {
  if (rows * d < kParallelElements || omp_get_max_threads() == 1 || omp_in_parallel()) {
    f(int64_t{0}, d);
    return;
  }
#pragma omp parallel
  {
    const int64_t t = omp_get_thread_num(), nt = omp_get_num_threads();
    f(d * t / nt, d * (t + 1) / nt);
  }
}
}  // namespace

void RunningNormImpl::update(const torch::Tensor& x) { update_rows(x, torch::Tensor()); }

void RunningNormImpl::update_rows(const torch::Tensor& x, const torch::Tensor& keep) {
  std::vector<double> moments;
  batch_moments(x, keep, &moments);
  merge_moments(moments.data());
}

namespace {
// Every picked row inside x [N, dim]: index in [0, N / group).
void check_pick(const torch::Tensor& x, const RowPick& pick) {
  const int64_t samples = x.size(0) / pick.group;
  TORCH_CHECK(pick.group >= 1 && x.size(0) % pick.group == 0, "RunningNorm: ", x.size(0),
              " rows are not whole groups of ", pick.group);
  for (int64_t i = 0; i < pick.count; ++i)
    TORCH_CHECK(pick.index[i] >= 0 && pick.index[i] < samples, "RunningNorm: picked row ", pick.index[i],
                " outside the ", samples, " rows");
}
}  // namespace

void RunningNormImpl::update_picked(const torch::Tensor& x, const torch::Tensor& keep, const RowPick& pick) {
  check_tensor(x, "x", {-1, dim_}, torch::kFloat32);
  check_pick(x, pick);
  std::vector<double> moments;
  batch_moments(x, keep, &moments, &pick);
  merge_moments(moments.data());
}

void RunningNormImpl::batch_moments(const torch::Tensor& x_in, const torch::Tensor& keep_in,
                                    std::vector<double>* out, const RowPick* pick) const {
  check_tensor(x_in, "x", {-1, dim_}, torch::kFloat32);
  const auto x = x_in.contiguous();
  const auto keep = keep_in.defined() ? keep_in.contiguous() : keep_in;
  const int64_t rows = pick != nullptr ? pick->rows() : x.size(0), d = dim_;
  const float* x0 = x.data_ptr<float>();
  const bool* k0 = keep.defined() ? keep.data_ptr<bool>() : nullptr;
  // f(r) for x's row r of every batch row, in batch order: x's rows, or the picked ones read in
  // place (index[k] * group + j), walked without RowPick::at's division per row.
  const auto for_each_kept = [&](const auto& f) {
    const auto visit = [&](int64_t r) {
      if (k0 == nullptr || k0[r]) f(r);
    };
    if (pick == nullptr) {
      for (int64_t r = 0; r < rows; ++r) visit(r);
      return;
    }
    for (int64_t k = 0; k < pick->count; ++k)
      for (int64_t r = pick->index[k] * pick->group, end = r + pick->group; r < end; ++r) visit(r);
  };
  const std::size_t at = out->size();
  out->resize(at + 1 + 2 * static_cast<std::size_t>(d), 0.0);
  double* batch_mean = out->data() + at + 1;
  double* batch_m2 = batch_mean + d;
  int64_t n = 0;
  for_each_kept([&n](int64_t) { ++n; });
  (*out)[at] = static_cast<double>(n);
  if (n == 0) return;
  over_column_shares(rows, d, [&](int64_t c0, int64_t c1) {
    // Each thread sums into its own buffer (the shared arrays' neighbouring columns would sit in
    // one cache line written by both threads), from 0 in row order as before: the same bits.
    std::vector<double> sum(static_cast<std::size_t>(c1 - c0), 0.0), m2(sum.size(), 0.0);
    double* s = sum.data();
    double* q = m2.data();
    for_each_kept([&](int64_t r) {
      const float* xr = x0 + r * d;
      for (int64_t c = c0; c < c1; ++c) s[c - c0] += xr[c];
    });
    for (int64_t c = c0; c < c1; ++c) s[c - c0] /= static_cast<double>(n);
    for_each_kept([&](int64_t r) {  // second pass: squared deviations about the batch mean
      const float* xr = x0 + r * d;
      for (int64_t c = c0; c < c1; ++c) {
        const double dev = xr[c] - s[c - c0];
        q[c - c0] += dev * dev;
      }
    });
    std::copy(sum.begin(), sum.end(), batch_mean + c0);
    std::copy(m2.begin(), m2.end(), batch_m2 + c0);
  });
}

void RunningNormImpl::merge_moments(const double* moments) {
  const double batch_count = moments[0];
  if (batch_count == 0.0) return;
  const double* batch_mean = moments + 1;
  const double* batch_m2 = batch_mean + dim_;
  // Chan et al.'s merge of (count, mean, var) with the batch, as gym's RunningMeanStd.
  torch::NoGradGuard no_grad;
  double* mean = mean_.data_ptr<double>();
  double* var = var_.data_ptr<double>();
  const double count = count_.item<double>(), total = count + batch_count;
  for (int64_t c = 0; c < dim_; ++c) {
    const double delta = batch_mean[c] - mean[c];
    const double m2 = var[c] * count + batch_m2[c] + delta * delta * (count * batch_count / total);
    mean[c] += delta * (batch_count / total);
    var[c] = m2 / total;
  }
  count_.fill_(total);
}

namespace {
// Moments b (as batch_moments writes them, width d) merged into a, Chan et al.: the moments of
// the union of both batches.
void combine_moments(double* a, const double* b, int64_t d) {
  const double na = a[0], nb = b[0], n = na + nb;
  if (nb == 0.0) return;
  if (na == 0.0) {
    std::copy(b, b + 1 + 2 * d, a);
    return;
  }
  for (int64_t c = 0; c < d; ++c) {
    const double delta = b[1 + c] - a[1 + c];
    a[1 + d + c] += b[1 + d + c] + delta * delta * (na * nb / n);
    a[1 + c] += delta * (nb / n);
  }
  a[0] = n;
}
}  // namespace

void ObsNormalizerImpl::set_moments_gather(MomentsGather gather) {
  gather_ = std::move(gather);
  pending_.clear();
}

void ObsNormalizerImpl::hold_back(const torch::Tensor& ego, const torch::Tensor& extra, const torch::Tensor& ado,
                                  const torch::Tensor& alive, const torch::Tensor& task) {
  std::vector<double> batch;
  ego_->batch_moments(ego, torch::Tensor(), &batch);
  extra_->batch_moments(extra, torch::Tensor(), &batch);
  ado_norm_->batch_moments(ado.reshape({-1, dims_.d_ado}), alive.reshape({-1}), &batch);
  task_->batch_moments(task, torch::Tensor(), &batch);
  if (pending_.empty()) {
    pending_ = std::move(batch);
    return;
  }
  std::size_t at = 0;
  for (const RunningNorm* norm : {&ego_, &extra_, &ado_norm_, &task_}) {
    combine_moments(pending_.data() + at, batch.data() + at, (*norm)->dim());
    at += 1 + 2 * static_cast<std::size_t>((*norm)->dim());
  }
}

void ObsNormalizerImpl::sync_replicas() {
  if (!gather_) return;
  // A replica that saw no batch since the last sync sends zero counts of the same width.
  std::vector<double> mine = pending_;
  if (mine.empty()) {
    for (const RunningNorm* norm : {&ego_, &extra_, &ado_norm_, &task_})
      mine.resize(mine.size() + 1 + 2 * static_cast<std::size_t>((*norm)->dim()), 0.0);
  }
  pending_.clear();
  const std::vector<double> all = gather_(mine);
  TORCH_CHECK(!all.empty() && all.size() % mine.size() == 0, "ObsNormalizer: the replicas' moments do not line up");
  const std::size_t width = mine.size(), replicas = all.size() / width;
  std::vector<double> pooled(all.begin(), all.begin() + static_cast<std::ptrdiff_t>(width));
  const std::array<RunningNorm*, 4> norms{&ego_, &extra_, &ado_norm_, &task_};
  for (std::size_t r = 1; r < replicas; ++r) {
    std::size_t at = 0;
    for (RunningNorm* norm : norms) {
      combine_moments(pooled.data() + at, all.data() + r * width + at, (*norm)->dim());
      at += 1 + 2 * static_cast<std::size_t>((*norm)->dim());
    }
  }
  std::size_t at = 0;
  for (RunningNorm* norm : norms) {
    (*norm)->merge_moments(pooled.data() + at);
    at += 1 + 2 * static_cast<std::size_t>((*norm)->dim());
  }
}

torch::Tensor RunningNormImpl::normalize(const torch::Tensor& x) const { return normalize_rows(x, torch::Tensor()); }

torch::Tensor RunningNormImpl::normalize_rows(const torch::Tensor& x, const torch::Tensor& keep) const {
  return normalize_impl(x, keep, nullptr);
}

torch::Tensor RunningNormImpl::normalize_picked(const torch::Tensor& x, const torch::Tensor& keep,
                                                const RowPick& pick) const {
  check_tensor(x, "x", {-1, dim_}, torch::kFloat32);
  check_pick(x, pick);
  return normalize_impl(x, keep, &pick);
}

torch::Tensor RunningNormImpl::normalize_impl(const torch::Tensor& x_in, const torch::Tensor& keep_in,
                                              const RowPick* pick) const {
  TORCH_CHECK(x_in.dim() >= 1 && x_in.size(-1) == dim_, "RunningNorm: last dimension of x is ", x_in.size(-1),
              ", expected ", dim_);
  TORCH_CHECK(x_in.scalar_type() == torch::kFloat32, "RunningNorm: x must be float32");
  const auto x = x_in.contiguous();
  const auto keep = keep_in.defined() ? keep_in.contiguous() : keep_in;
  auto out = pick != nullptr ? torch::empty({pick->rows(), dim_}) : torch::empty_like(x);
  const int64_t d = dim_, rows = pick != nullptr ? pick->rows() : (d > 0 ? x.numel() / d : 0);
  const float* xp = x.data_ptr<float>();
  const bool* kp = keep.defined() ? keep.data_ptr<bool>() : nullptr;
  float* op = out.data_ptr<float>();
  std::vector<float> m(static_cast<std::size_t>(d)), s(static_cast<std::size_t>(d));
  const kernels::NormTerms terms = float_terms(m.data(), s.data());
#pragma omp parallel for schedule(static) if (rows * d >= kParallelElements && !omp_in_parallel())
  for (int64_t i = 0; i < rows; ++i) {
    const int64_t src = pick != nullptr ? pick->at(i) : i;
    kernels::normalize_row(terms, xp + src * d, kp == nullptr || kp[src], op + i * d);
  }
  return out;
}

kernels::NormTerms RunningNormImpl::float_terms(float* mean_out, float* inv_std_out) const {
  const double* mean = mean_.data_ptr<double>();
  const double* var = var_.data_ptr<double>();
  for (int64_t c = 0; c < dim_; ++c) {
    mean_out[c] = static_cast<float>(mean[c]);
    inv_std_out[c] = static_cast<float>(1.0 / std::sqrt(var[c] + eps_));
  }
  return kernels::NormTerms{mean_out, inv_std_out, static_cast<float>(clip_), dim_};
}

ObsNormalizerImpl::ObsNormalizerImpl(const ObsDims& dims, double clip) : dims_(dims) {
  ego_ = register_module("ego", RunningNorm(dims.d_ego, clip));
  // One normaliser for the 3-wide input of either level: prev_action (HL) or goal (LL).
  TORCH_CHECK(dims.d_prev_action == dims.d_goal, "ObsNormalizer: prev_action and goal widths must match");
  extra_ = register_module("extra", RunningNorm(dims.d_goal, clip));
  ado_norm_ = register_module("ado", RunningNorm(dims.d_ado, clip));
  task_ = register_module("task", RunningNorm(dims.d_task, clip));
}

torch::Tensor ObsNormalizerImpl::ado_(const torch::Tensor& ado, const torch::Tensor& alive, bool update_stats) {
  const auto rows = ado.reshape({-1, dims_.d_ado}), keep = alive.reshape({-1});
  if (update_stats) ado_norm_->update_rows(rows, keep);
  return ado_norm_->normalize_rows(rows, keep).view(ado.sizes());
}

HlObs ObsNormalizerImpl::normalize(const HlObs& obs, bool update_stats) {
  check_obs(obs, dims_);
  torch::NoGradGuard no_grad;
  if (update_stats && gather_) {
    hold_back(obs.ego, obs.prev_action, obs.ado, obs.ado_alive, obs.task);
    update_stats = false;
  }
  if (update_stats) {
    ego_->update(obs.ego);
    extra_->update(obs.prev_action);
    task_->update(obs.task);
  }
  return {ego_->normalize(obs.ego), extra_->normalize(obs.prev_action), ado_(obs.ado, obs.ado_alive, update_stats),
          obs.ado_alive, task_->normalize(obs.task)};
}

LlObs ObsNormalizerImpl::normalize(const LlObs& obs, bool update_stats) {
  check_obs(obs, dims_);
  torch::NoGradGuard no_grad;
  if (update_stats) absorb(obs, torch::Tensor());
  return {ego_->normalize(obs.ego), extra_->normalize(obs.goal), ado_(obs.ado, obs.ado_alive, false), obs.ado_alive,
          task_->normalize(obs.task)};
}

void ObsNormalizerImpl::absorb(const LlObs& obs, const torch::Tensor& rows_in) {
  check_obs(obs, dims_);
  torch::NoGradGuard no_grad;
  if (!rows_in.defined()) {
    if (gather_) {
      hold_back(obs.ego, obs.goal, obs.ado, obs.ado_alive, obs.task);
      return;
    }
    ego_->update(obs.ego);
    extra_->update(obs.goal);
    task_->update(obs.task);
    ado_norm_->update_rows(obs.ado.reshape({-1, dims_.d_ado}), obs.ado_alive.reshape({-1}));
    return;
  }
  check_tensor(rows_in, "rows", {-1}, torch::kInt64);
  // Replicas hold batches back through hold_back's gathered path.
  if (gather_) {
    const LlObs picked = index_rows(obs, rows_in);
    hold_back(picked.ego, picked.goal, picked.ado, picked.ado_alive, picked.task);
    return;
  }
  const auto rows = rows_in.contiguous();
  const int64_t* idx = rows.data_ptr<int64_t>();
  const RowPick pick{idx, rows.numel(), 1}, pick_ado{idx, rows.numel(), dims_.n_other};
  ego_->update_picked(obs.ego, torch::Tensor(), pick);
  extra_->update_picked(obs.goal, torch::Tensor(), pick);
  task_->update_picked(obs.task, torch::Tensor(), pick);
  ado_norm_->update_picked(obs.ado.reshape({-1, dims_.d_ado}), obs.ado_alive.reshape({-1}), pick_ado);
}

LlObs ObsNormalizerImpl::normalize(const LlObs& obs, const torch::Tensor& rows_in, bool update_stats) {
  check_obs(obs, dims_);
  check_tensor(rows_in, "rows", {-1}, torch::kInt64);
  torch::NoGradGuard no_grad;
  if (update_stats) absorb(obs, rows_in);
  const auto rows = rows_in.contiguous();
  const int64_t n = rows.numel();
  const int64_t* idx = rows.data_ptr<int64_t>();
  const RowPick pick{idx, n, 1}, pick_ado{idx, n, dims_.n_other};
  const auto ado = obs.ado.reshape({-1, dims_.d_ado}), alive = obs.ado_alive.reshape({-1});
  return {ego_->normalize_picked(obs.ego, torch::Tensor(), pick), extra_->normalize_picked(obs.goal, torch::Tensor(), pick),
          ado_norm_->normalize_picked(ado, alive, pick_ado).view({n, dims_.n_other, dims_.d_ado}),
          obs.ado_alive.index_select(0, rows), task_->normalize_picked(obs.task, torch::Tensor(), pick)};
}

LlRawRows ObsNormalizerImpl::raw_fields(const std::array<const torch::Tensor*, 5>& raw, const torch::Tensor& rows,
                                        const std::array<const torch::Tensor*, 5>& out, std::vector<float>* terms) const {
  const char* names[5] = {"ego", "extra", "ado", "ado_alive", "task"};
  for (int f = 0; f < 5; ++f) {
    TORCH_CHECK(raw[f]->is_contiguous(), "ObsNormalizer::raw_rows: raw ", names[f], " must be contiguous");
    TORCH_CHECK(out[f]->is_contiguous(), "ObsNormalizer::raw_rows: out ", names[f], " must be contiguous");
  }
  const int64_t n = raw[0]->size(0), b = rows.defined() ? rows.numel() : n;
  TORCH_CHECK(out[0]->size(0) == b, "ObsNormalizer::raw_rows: out holds ", out[0]->size(0), " rows for ", b);
  LlRawRows r;
  if (rows.defined()) {
    check_tensor(rows, "rows", {-1}, torch::kInt64);
    TORCH_CHECK(rows.is_contiguous(), "ObsNormalizer::raw_rows: rows must be contiguous");
    const int64_t* p = rows.data_ptr<int64_t>();
    for (int64_t i = 0; i < b; ++i)
      TORCH_CHECK(p[i] >= 0 && p[i] < n, "ObsNormalizer::raw_rows: row ", p[i], " outside the ", n, " rows");
    r.index = p;
  }
  // Each field's float mean and inverse std side by side in the scratch, sized once here so the
  // pointers stay valid.
  terms->resize(static_cast<std::size_t>(2 * (dims_.d_ego + dims_.d_goal + dims_.d_ado + dims_.d_task)));
  float* t = terms->data();
  const auto next = [&t](const RunningNorm& norm) {
    const kernels::NormTerms k = norm->float_terms(t, t + norm->dim());
    t += 2 * norm->dim();
    return k;
  };
  r.ego_norm = next(ego_);
  r.goal_norm = next(extra_);
  r.ado_norm = next(ado_norm_);
  r.task_norm = next(task_);
  r.ego = raw[0]->data_ptr<float>();
  r.goal = raw[1]->data_ptr<float>();
  r.ado = raw[2]->data_ptr<float>();
  r.ado_alive = raw[3]->data_ptr<bool>();
  r.task = raw[4]->data_ptr<float>();
  r.ego_out = out[0]->data_ptr<float>();
  r.goal_out = out[1]->data_ptr<float>();
  r.ado_out = out[2]->data_ptr<float>();
  r.ado_alive_out = out[3]->data_ptr<bool>();
  r.task_out = out[4]->data_ptr<float>();
  return r;
}

LlRawRows ObsNormalizerImpl::raw_rows(const LlObs& raw, const torch::Tensor& rows, const LlObs& out,
                                      std::vector<float>* terms) const {
  check_obs(raw, dims_);
  check_obs(out, dims_);
  return raw_fields({&raw.ego, &raw.goal, &raw.ado, &raw.ado_alive, &raw.task}, rows,
                    {&out.ego, &out.goal, &out.ado, &out.ado_alive, &out.task}, terms);
}

LlRawRows ObsNormalizerImpl::raw_rows(const HlObs& raw, const torch::Tensor& rows, const HlObs& out,
                                      std::vector<float>* terms) const {
  check_obs(raw, dims_);
  check_obs(out, dims_);
  return raw_fields({&raw.ego, &raw.prev_action, &raw.ado, &raw.ado_alive, &raw.task}, rows,
                    {&out.ego, &out.prev_action, &out.ado, &out.ado_alive, &out.task}, terms);
}

}  // namespace f16race::models
