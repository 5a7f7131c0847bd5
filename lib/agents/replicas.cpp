#include "agents/replicas.hpp"

#include <algorithm>

namespace f16race::agents {

void sum_weighted_gradients(const std::vector<torch::Tensor>& params, double weight, std::vector<double>& extra,
                            const Replicas& replicas) {
  int64_t n = static_cast<int64_t>(extra.size());
  for (const auto& p : params) n += p.numel();
  auto flat = torch::zeros({n});  // one buffer, one reduction
  float* f = flat.data_ptr<float>();
  int64_t at = 0;
  for (const auto& p : params) {
    if (const auto& g = p.grad(); g.defined()) {
      const auto scaled = (g * static_cast<float>(weight)).contiguous();
      std::copy(scaled.data_ptr<float>(), scaled.data_ptr<float>() + p.numel(), f + at);
    }
    at += p.numel();
  }
  for (std::size_t k = 0; k < extra.size(); ++k) f[at + static_cast<int64_t>(k)] = static_cast<float>(extra[k]);
  replicas.sum_floats(f, n);
  at = 0;
  for (const auto& p : params) {
    // Own tensors, not views of `flat`: the optimiser detaches gradients in place.
    p.mutable_grad() = flat.slice(0, at, at + p.numel()).view(p.sizes()).clone();
    at += p.numel();
  }
  for (std::size_t k = 0; k < extra.size(); ++k) extra[k] = f[at + static_cast<int64_t>(k)];
}

}  // namespace f16race::agents
