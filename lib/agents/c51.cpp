#include "agents/c51.hpp"

#include <cmath>

#include "models/obs.hpp"

namespace f16race::agents {

torch::Tensor c51_project(const torch::Tensor& next_probs, const torch::Tensor& reward, const torch::Tensor& discount,
                          const C51Support& support) {
  const int64_t k = support.n_atoms;
  TORCH_CHECK(k > 1 && support.v_max > support.v_min, "c51_project: need n_atoms > 1 and v_max > v_min");
  models::check_tensor(next_probs, "next_probs", {-1, k}, torch::kFloat32);
  const int64_t n = next_probs.size(0);
  models::check_tensor(reward, "reward", {n}, torch::kFloat32);
  models::check_tensor(discount, "discount", {n}, torch::kFloat32);

  // Positions in float64: b = (Tz - v_min) / dz lands exactly on an integer for a target on an
  // atom, so the l == u case below really fires instead of leaking 1e-7 of mass to a neighbour.
  const auto atoms = torch::linspace(support.v_min, support.v_max, k, torch::kFloat64);
  const auto tz = (reward.to(torch::kFloat64).unsqueeze(1) + discount.to(torch::kFloat64).unsqueeze(1) * atoms)
                      .clamp(support.v_min, support.v_max);
  auto b = ((tz - support.v_min) / support.delta()).clamp(0.0, static_cast<double>(k - 1));
  // Snap values within 1e-9 of an integer (float64 rounding of z_k) onto it.
  const auto rounded = b.round();
  b = torch::where((b - rounded).abs() < 1e-9, rounded, b);
  const auto lower = b.floor();
  const auto upper = b.ceil();
  const auto p = next_probs.to(torch::kFloat64);
  const auto same = (upper == lower).to(torch::kFloat64);
  const auto mass_lower = p * (upper - b + same);  // whole mass to `lower` when on an atom
  const auto mass_upper = p * (b - lower);
  const auto row = (torch::arange(n, torch::kInt64) * k).unsqueeze(1);
  auto projected = torch::zeros({n * k}, torch::kFloat64);
  projected.index_add_(0, (lower.to(torch::kInt64) + row).reshape({-1}), mass_lower.reshape({-1}));
  projected.index_add_(0, (upper.to(torch::kInt64) + row).reshape({-1}), mass_upper.reshape({-1}));
  return projected.view({n, k}).to(torch::kFloat32);
}

}  // namespace f16race::agents
