#pragma once
// Which policy flies each aircraft, and each policy's rows, so that every network runs only on
// the aircraft it flies: the learner and a pool snapshot in training, the entries of a
// tournament, the two sides of a replay. One place for the gather-act-scatter loop they share.
#include <torch/torch.h>

#include <algorithm>
#include <cstdint>
#include <vector>

namespace f16race::train {

class PolicyRows {
 public:
  PolicyRows(int n_policies, int n_aircraft);
  // owner[i]: the policy flying aircraft i, or -1 for none (an idle env, a scripted pilot, a
  // fixed-HL control, an env whose HL is not due). Rows are rebuilt only when owners change.
  void assign(const std::vector<int>& owner);
  int n_policies() const { return static_cast<int>(rows_.size()); }
  int n_aircraft() const { return static_cast<int>(owner_.size()); }
  int owner(int i) const { return owner_[i]; }
  // The aircraft policy p flies, ascending: int64 [M_p].
  const torch::Tensor& rows(int p) const { return rows_[p]; }
  // Where aircraft i sits in its owner's rows (-1: no owner).
  int position(int i) const { return position_[i]; }
  // True when policy p flies every aircraft in order, so its rows are the whole batch.
  bool owns_all(int p) const { return rows_[p].numel() == n_aircraft(); }

 private:
  std::vector<int> owner_, position_;
  std::vector<torch::Tensor> rows_;
};

// Writes row k of `values` [M, W] (contiguous or not) into row idx[k] of the flat [N, W] array
// `dst`, for every k: the actions or bins of one policy into the env's input.
template <class T>
void scatter_rows(const torch::Tensor& idx, const torch::Tensor& values, T* dst) {
  const torch::Tensor v = values.contiguous();
  const T* src = v.data_ptr<T>();
  const std::int64_t w = v.dim() > 1 ? v.size(1) : 1;
  const std::int64_t* r = idx.data_ptr<std::int64_t>();
  for (std::int64_t k = 0; k < idx.numel(); ++k) std::copy(src + k * w, src + (k + 1) * w, dst + r[k] * w);
}

}  // namespace f16race::train
