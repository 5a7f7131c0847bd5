#include "models/dense_linear.hpp"

#include <string>

#include "models/kernels/fixed_order_gemm.hpp"

namespace f16race::models {
namespace {

constexpr int64_t kRowGrain = 96;  // rows per intra-op task (16 tiles of 6)

// C [m, n] = A B (+ bias) over rows split across the intra-op threads.
void gemm_parallel(const kernels::GemmArgs& g) {
  at::parallel_for(0, g.m, kRowGrain, [&](int64_t begin, int64_t end) { kernels::fixed_order_gemm(g, begin, end); });
}

class DenseLinear : public torch::autograd::Function<DenseLinear> {
 public:
  static torch::Tensor forward(torch::autograd::AutogradContext* ctx, const torch::Tensor& x_in,
                               const torch::Tensor& weight_in, const torch::Tensor& bias_in) {
    const int64_t out = weight_in.size(0), in = weight_in.size(1);
    const auto x = x_in.reshape({-1, in}).contiguous();
    const auto weight = weight_in.contiguous();
    auto weight_t = torch::empty({in, out}, weight.options());  // [in, out]: B of the forward product
    kernels::transpose_weight(weight.data_ptr<float>(), out, in, weight_t.data_ptr<float>());
    const auto bias = bias_in.defined() ? bias_in.contiguous() : bias_in;
    auto y = torch::empty({x.size(0), out}, x.options());
    kernels::GemmArgs g;
    g.m = x.size(0);
    g.n = out;
    g.k = in;
    g.a = x.data_ptr<float>();
    g.a_row_stride = in;
    g.b = weight_t.data_ptr<float>();
    g.b_row_stride = out;
    g.bias = bias.defined() ? bias.data_ptr<float>() : nullptr;
    g.c = y.data_ptr<float>();
    g.c_row_stride = out;
    gemm_parallel(g);
    ctx->save_for_backward({x, weight});
    ctx->saved_data["has_bias"] = bias.defined();
    auto shape = x_in.sizes().vec();
    shape.back() = out;
    return y.view(shape);
  }

  static torch::autograd::variable_list backward(torch::autograd::AutogradContext* ctx,
                                                 torch::autograd::variable_list grads) {
    const auto saved = ctx->get_saved_variables();
    const auto &x = saved[0], &weight = saved[1];
    const int64_t m = x.size(0), out = weight.size(0), in = weight.size(1);
    const auto grad_y = grads[0].reshape({m, out}).contiguous();
    const float* gy = grad_y.data_ptr<float>();
    torch::Tensor grad_x, grad_w, grad_b;
    if (ctx->needs_input_grad(0)) {  // dx = dy W: inner dimension out, W's rows are B's
      grad_x = torch::empty({m, in}, x.options());
      kernels::GemmArgs g;
      g.m = m, g.n = in, g.k = out;
      g.a = gy, g.a_row_stride = out;
      g.b = weight.data_ptr<float>(), g.b_row_stride = in;
      g.c = grad_x.data_ptr<float>(), g.c_row_stride = in;
      gemm_parallel(g);
    }
    if (ctx->needs_input_grad(1)) {  // dW = dy^T x: inner dimension the rows, A read transposed
      grad_w = torch::empty({out, in}, x.options());
      kernels::GemmArgs g;
      g.m = out, g.n = in, g.k = m;
      g.a = gy, g.a_row_stride = 1, g.a_col_stride = out;
      g.b = x.data_ptr<float>(), g.b_row_stride = in;
      g.c = grad_w.data_ptr<float>(), g.c_row_stride = in;
      at::parallel_for(0, out, 6, [&](int64_t begin, int64_t end) { kernels::fixed_order_gemm(g, begin, end); });
    }
    if (ctx->needs_input_grad(2) && ctx->saved_data["has_bias"].toBool()) {
      grad_b = torch::empty({out}, x.options());
      kernels::column_sums(gy, m, out, 0, out, grad_b.data_ptr<float>());
    }
    if (grad_x.defined()) {
      auto shape = grads[0].sizes().vec();
      shape.back() = in;
      grad_x = grad_x.view(shape);
    }
    return {grad_x, grad_w, grad_b};
  }
};

}  // namespace

torch::Tensor dense_linear(const torch::Tensor& x, const torch::Tensor& weight, const torch::Tensor& bias) {
  TORCH_CHECK(x.scalar_type() == torch::kFloat32 && weight.scalar_type() == torch::kFloat32,
              "dense_linear: float tensors only");
  TORCH_CHECK(weight.dim() == 2 && x.dim() >= 1 && x.size(-1) == weight.size(1), "dense_linear: x [..., ",
              weight.size(1), "] expected for weight [", weight.size(0), ", ", weight.size(1), "], got ", x.sizes());
  TORCH_CHECK(!bias.defined() || (bias.dim() == 1 && bias.size(0) == weight.size(0)), "dense_linear: bias [",
              weight.size(0), "] expected");
  return DenseLinear::apply(x, weight, bias);
}

torch::Tensor forward_mlp(const torch::nn::Sequential& mlp, torch::Tensor x) {
  for (const auto& layer : mlp->children()) {
    if (const auto* linear = layer->as<torch::nn::LinearImpl>()) x = dense_linear(x, linear->weight, linear->bias);
    else if (layer->as<torch::nn::TanhImpl>() != nullptr) x = torch::tanh(x);
    else if (layer->as<torch::nn::ReLUImpl>() != nullptr) x = torch::relu(x);
    else TORCH_CHECK(false, "forward_mlp: a ", layer->name(), " layer; Linear, Tanh and ReLU only");
  }
  return x;
}

}  // namespace f16race::models
