#include "train/policy_rows.hpp"

#include <stdexcept>
#include <string>

namespace f16race::train {

PolicyRows::PolicyRows(int n_policies, int n_aircraft)
    : owner_(static_cast<std::size_t>(n_aircraft), -2), position_(static_cast<std::size_t>(n_aircraft), -1) {
  rows_.assign(static_cast<std::size_t>(n_policies), torch::empty({0}, torch::kInt64));
}

void PolicyRows::assign(const std::vector<int>& owner) {
  if (owner.size() != owner_.size())
    throw std::logic_error("PolicyRows::assign: " + std::to_string(owner.size()) + " owners for " +
                           std::to_string(owner_.size()) + " aircraft");
  if (owner == owner_) return;
  owner_ = owner;
  std::vector<std::vector<std::int64_t>> r(rows_.size());
  for (std::size_t i = 0; i < owner_.size(); ++i) {
    const int p = owner_[i];
    if (p < -1 || p >= n_policies())
      throw std::logic_error("PolicyRows::assign: aircraft " + std::to_string(i) + " has owner " + std::to_string(p));
    position_[i] = p >= 0 ? static_cast<int>(r[p].size()) : -1;
    if (p >= 0) r[p].push_back(static_cast<std::int64_t>(i));
  }
  for (std::size_t p = 0; p < rows_.size(); ++p) rows_[p] = torch::tensor(r[p], torch::kInt64);
}

}  // namespace f16race::train
