#include "agents/eigen_mirror.hpp"

#include <stdexcept>

namespace f16race::agents {

void EigenMirror::follow(std::vector<torch::Tensor> params, WeightsOf weights) {
  params_ = std::move(params);
  weights_ = std::move(weights);
  copied_.clear();
}

models::AttentionMlpForward& EigenMirror::current() {
  if (!weights_) throw std::logic_error("EigenMirror::current before follow");
  bool same = copied_.size() == params_.size();
  for (std::size_t k = 0; same && k < params_.size(); ++k)
    same = copied_[k].first == params_[k].data_ptr() && copied_[k].second == params_[k]._version();
  if (!same) {
    forward_.set_weights(weights_());  // throws and keeps the old copy on a shape error: copied_ stays stale
    copied_.clear();
    for (const auto& p : params_) copied_.emplace_back(p.data_ptr(), p._version());
  }
  return forward_;
}

}  // namespace f16race::agents
