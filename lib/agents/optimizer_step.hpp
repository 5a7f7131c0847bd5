#pragma once
// One optimiser step of PPO and Expected SARSA in plain loops over each parameter's memory: the
// chunks' gradients summed into the parameter's own gradient buffer, the global norm clipped and
// Adam applied, instead of ~10 LibTorch ops per parameter tensor (issue 13: a network's ~20 small
// tensors cost more in op dispatch than in arithmetic). The state stays in torch::optim::Adam,
// so checkpoints (agents/checkpoint.hpp) are unchanged.
#include <torch/torch.h>

#include <vector>

namespace f16race::agents {

// params[p].grad() becomes the sum, in chunk order, of chunk_grads[c][p] over the chunks whose
// gradient for p is defined (an empty list: a chunk without rows), written into the gradient
// buffer the parameter already owns when it has one. Where no chunk has a gradient for p it
// becomes zeros (zero_unused) or undefined (Adam then skips p, as LibTorch's does).
void sum_chunk_gradients(const std::vector<torch::Tensor>& params,
                         const std::vector<const std::vector<torch::Tensor>*>& chunk_grads, bool zero_unused);

// What torch::nn::utils::clip_grad_norm_(params, max_grad_norm) followed by opt.step() does, for
// every parameter of `opt` with a defined gradient: the total 2-norm (summed in double), the
// gradients scaled by min(1, max_grad_norm / (norm + 1e-6)), Adam's moments and update (bias
// corrections in double, the rest in float; equal to LibTorch's to float rounding). The
// gradients are left unscaled. Returns the norm before clipping. Weight decay or AMSGrad: LibTorch's
// own ops.
double clip_and_adam_step(torch::optim::Adam& opt, double max_grad_norm);

}  // namespace f16race::agents
