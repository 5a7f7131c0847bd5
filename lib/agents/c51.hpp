#pragma once
// C51 categorical projection (Bellemare et al. 2017, Algorithm 1): the distribution of
// r + discount * Z, with Z on the atoms z_k = v_min + k dz (dz = (v_max - v_min) / (K - 1)) and
// probabilities p, is clipped to [v_min, v_max] and its mass split between the two neighbouring
// atoms in proportion to closeness. Mass is conserved; a target exactly on an atom keeps all
// of its mass there.
//
//   c51_project(next_probs [N, K], reward [N], discount [N]) -> [N, K]
//   (discount = gamma * (1 - done) per sample)
#include <torch/torch.h>

namespace f16race::agents {

struct C51Support {
  double v_min = -10.0;
  double v_max = 10.0;
  int64_t n_atoms = 51;
  double delta() const { return (v_max - v_min) / static_cast<double>(n_atoms - 1); }
  torch::Tensor atoms() const { return torch::linspace(v_min, v_max, n_atoms); }
};

torch::Tensor c51_project(const torch::Tensor& next_probs, const torch::Tensor& reward, const torch::Tensor& discount,
                          const C51Support& support);

}  // namespace f16race::agents
