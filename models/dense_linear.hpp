#pragma once
// A Linear layer's y = x W^T + b on the project's fixed-order kernels (models/kernels/
// fixed_order_gemm.hpp), forward and backward as one autograd node: the same bits on every CPU at
// AVX-512's width where the CPU has it, instead of OpenBLAS's kernels pinned to Haswell's. Every
// network's Linear layers run through it; torch::nn::functional::linear stays the tests' oracle.
#include <torch/torch.h>

namespace f16race::models {

// x [..., in] float, weight [out, in], bias [out] (or undefined) -> [..., out]. Differentiable in
// all three; rows of x are split over LibTorch's intra-op threads (the same bits at any split).
torch::Tensor dense_linear(const torch::Tensor& x, const torch::Tensor& weight, const torch::Tensor& bias);
inline torch::Tensor dense_linear(const torch::Tensor& x, const torch::nn::Linear& layer) {
  return dense_linear(x, layer->weight, layer->bias);
}

// An MLP held as a torch::nn::Sequential of Linear layers and Tanh or ReLU activations, with its
// Linear layers through dense_linear.
torch::Tensor forward_mlp(const torch::nn::Sequential& mlp, torch::Tensor x);

}  // namespace f16race::models
