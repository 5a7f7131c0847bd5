#include "models/obs.hpp"

#include <sstream>

namespace f16race::models {

void check_tensor(const torch::Tensor& t, const char* name, std::initializer_list<int64_t> shape,
                  torch::ScalarType dtype) {
  TORCH_CHECK(t.defined(), "tensor '", name, "' is undefined");
  TORCH_CHECK(t.scalar_type() == dtype, "tensor '", name, "' has dtype ", t.scalar_type(), ", expected ", dtype);
  bool ok = t.dim() == static_cast<int64_t>(shape.size());
  int64_t d = 0;
  for (int64_t s : shape) {
    if (!ok) break;
    ok = (s < 0 || t.size(d) == s);
    ++d;
  }
  if (!ok) {
    std::ostringstream want;
    want << "[";
    d = 0;
    for (int64_t s : shape) want << (d++ ? ", " : "") << (s < 0 ? std::string("*") : std::to_string(s));
    want << "]";
    TORCH_CHECK(false, "tensor '", name, "' has shape ", t.sizes(), ", expected ", want.str());
  }
}

namespace {
// Every check an HL and an LL observation share; `extra` is the one tensor they differ in
// (the previous HL action or the goal) and its width.
template <class Obs>
int64_t check_common(const Obs& obs, const ObsDims& dims, const torch::Tensor& extra, const char* extra_name,
                     int64_t d_extra) {
  check_tensor(obs.ego, "ego", {-1, dims.d_ego}, torch::kFloat32);
  const int64_t b = obs.ego.size(0);
  check_tensor(extra, extra_name, {b, d_extra}, torch::kFloat32);
  check_tensor(obs.ado, "ado", {b, dims.n_other, dims.d_ado}, torch::kFloat32);
  check_tensor(obs.ado_alive, "ado_alive", {b, dims.n_other}, torch::kBool);
  check_tensor(obs.task, "task", {b, dims.d_task}, torch::kFloat32);
  return b;
}
}  // namespace

int64_t check_obs(const HlObs& obs, const ObsDims& dims) {
  return check_common(obs, dims, obs.prev_action, "prev_action", dims.d_prev_action);
}

int64_t check_obs(const LlObs& obs, const ObsDims& dims) { return check_common(obs, dims, obs.goal, "goal", dims.d_goal); }

HlObs index_rows(const HlObs& o, const torch::Tensor& i) {
  return {o.ego.index_select(0, i), o.prev_action.index_select(0, i), o.ado.index_select(0, i),
          o.ado_alive.index_select(0, i), o.task.index_select(0, i)};
}
LlObs index_rows(const LlObs& o, const torch::Tensor& i) {
  return {o.ego.index_select(0, i), o.goal.index_select(0, i), o.ado.index_select(0, i),
          o.ado_alive.index_select(0, i), o.task.index_select(0, i)};
}

namespace {
// ado_alive [B, n_other] read in place (a contiguous copy only if it is not): others alive per row.
struct AliveRows {
  torch::Tensor alive;
  int64_t rows = 0, n = 0;
  const bool* p = nullptr;
  explicit AliveRows(const torch::Tensor& ado_alive) {
    check_tensor(ado_alive, "ado_alive", {-1, -1}, torch::kBool);
    alive = ado_alive.contiguous();
    rows = alive.size(0), n = alive.size(1), p = alive.data_ptr<bool>();
  }
  int64_t operator()(int64_t i) const {
    int64_t c = 0;
    for (int64_t j = 0; j < n; ++j) c += p[i * n + j] ? 1 : 0;
    return c;
  }
};
}  // namespace

std::vector<int64_t> alive_per_row(const torch::Tensor& ado_alive) {
  const AliveRows alive(ado_alive);
  std::vector<int64_t> count(static_cast<std::size_t>(alive.rows));
  for (int64_t i = 0; i < alive.rows; ++i) count[static_cast<std::size_t>(i)] = alive(i);
  return count;
}

int64_t count_alive(const torch::Tensor& ado_alive, const torch::Tensor& index) {
  const AliveRows alive(ado_alive);
  int64_t total = 0;
  if (!index.defined()) {
    for (int64_t i = 0; i < alive.rows; ++i) total += alive(i);
    return total;
  }
  check_tensor(index, "index", {-1}, torch::kInt64);
  const auto idx = index.contiguous();
  const int64_t* r = idx.data_ptr<int64_t>();
  for (int64_t k = 0; k < idx.numel(); ++k) {
    TORCH_CHECK(r[k] >= 0 && r[k] < alive.rows, "count_alive: row ", r[k], " outside the ", alive.rows, " rows");
    total += alive(r[k]);
  }
  return total;
}

HlObs flatten2(const HlObs& o) {
  return {o.ego.flatten(0, 1), o.prev_action.flatten(0, 1), o.ado.flatten(0, 1), o.ado_alive.flatten(0, 1),
          o.task.flatten(0, 1)};
}
LlObs flatten2(const LlObs& o) {
  return {o.ego.flatten(0, 1), o.goal.flatten(0, 1), o.ado.flatten(0, 1), o.ado_alive.flatten(0, 1),
          o.task.flatten(0, 1)};
}

}  // namespace f16race::models
