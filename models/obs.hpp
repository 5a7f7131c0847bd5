#pragma once
// Observation tensors shared by the networks and agents, and the shape checks every forward
// uses. B is the number of aircraft samples (decentralised: one aircraft = one sample).
//
//   ego          [B, d_ego]            float32  s̄: state with angles as sin/cos
//   prev_action  [B, 3]                float32  previous low-level action (HL only)
//   goal         [B, 3]                float32  high-level goal (LL only)
//   ado          [B, n_other, d_ado]   float32  one row per other aircraft
//   ado_alive    [B, n_other]          bool     true = alive / observable
//   task         [B, d_task]           float32  track preview
#include <ATen/CPUGeneratorImpl.h>
#include <torch/torch.h>

#include <cstdint>
#include <initializer_list>
#include <vector>

namespace f16race::models {

// Feature sizes come from the race environment; there are no defaults on purpose.
struct ObsDims {
  int64_t d_ego = 0;
  int64_t d_ado = 0;
  int64_t d_task = 0;
  int64_t n_other = 0;
  int64_t d_prev_action = 3;  // HL input: the previous LL action (race::kActionDim)
  int64_t d_goal = 3;         // LL input: the goal (race::kGoalDim)
};

struct HlObs {
  torch::Tensor ego, prev_action, ado, ado_alive, task;
};

struct LlObs {
  torch::Tensor ego, goal, ado, ado_alive, task;
};

// Throws (TORCH_CHECK) naming `name` unless `t` is defined, has dtype `dtype` and the shape
// `shape`, where -1 matches any size.
void check_tensor(const torch::Tensor& t, const char* name, std::initializer_list<int64_t> shape,
                  torch::ScalarType dtype);

// Checks every field against `dims` with batch size B = ego.size(0); returns B.
int64_t check_obs(const HlObs& obs, const ObsDims& dims);
int64_t check_obs(const LlObs& obs, const ObsDims& dims);

// Rows `index` (int64 [M]) of every field.
HlObs index_rows(const HlObs& obs, const torch::Tensor& index);
LlObs index_rows(const LlObs& obs, const torch::Tensor& index);

// Other aircraft alive in each row of ado_alive (bool [B, n_other]), in plain loops (no LibTorch
// op per call): what the attention core's cost depends on, counted for `bench train`'s floor.
std::vector<int64_t> alive_per_row(const torch::Tensor& ado_alive);
// Their sum over the rows `index` (int64 [M]; undefined: all rows).
int64_t count_alive(const torch::Tensor& ado_alive, const torch::Tensor& index = torch::Tensor());

// Merges the two leading dimensions ([T, n, ...] -> [T*n, ...]) of every field.
HlObs flatten2(const HlObs& obs);
LlObs flatten2(const LlObs& obs);

// Explicit CPU generator: every draw during training and evaluation (actions, exploration,
// minibatches) goes through one of these, so runs are reproducible from their seed. The one
// use of LibTorch's global generator is the initial weights: LibTorch 1.13's nn::init functions
// take no generator, so the trainer and RunPolicy seed it (torch::manual_seed) right before the
// networks are built.
inline at::Generator make_generator(uint64_t seed) { return at::detail::createCPUGenerator(seed); }

}  // namespace f16race::models
