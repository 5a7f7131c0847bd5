#include "models/attention_encoder.hpp"

#include <cmath>

#include "models/dense_linear.hpp"
#include "models/kernels/masked_attention.hpp"

namespace f16race::models {
namespace {

// The masked multi-head attention core as one autograd node over the plain-loop kernels
// (models/kernels/masked_attention.hpp). Rows are split over LibTorch's intra-op threads; each
// row's arithmetic is the same whatever the split.
class MaskedAttention : public torch::autograd::Function<MaskedAttention> {
 public:
  // q [B, H*dh], k and v [B, N, H*dh], alive [B, N] bool -> attended [B, H*dh].
  static torch::Tensor forward(torch::autograd::AutogradContext* ctx, const torch::Tensor& q_in,
                               const torch::Tensor& k_in, const torch::Tensor& v_in, const torch::Tensor& alive_in,
                               int64_t n_heads) {
    const auto q = q_in.contiguous(), k = k_in.contiguous(), v = v_in.contiguous(), alive = alive_in.contiguous();
    const int64_t b = q.size(0), n = k.size(1), d = q.size(1);
    const kernels::AttentionShape shape{n, n_heads, d / n_heads};
    auto weights = torch::empty({b, n_heads, n}, q.options());
    auto attended = torch::empty({b, d}, q.options());
    const float *qp = q.data_ptr<float>(), *kp = k.data_ptr<float>(), *vp = v.data_ptr<float>();
    const bool* ap = alive.data_ptr<bool>();
    float *wp = weights.data_ptr<float>(), *op = attended.data_ptr<float>();
    at::parallel_for(0, b, 256, [&](int64_t begin, int64_t end) {
      kernels::masked_attention_forward(shape, begin, end, qp, kp, vp, ap, wp, op);
    });
    if (ctx != nullptr) {
      ctx->save_for_backward({q, k, v, weights});
      ctx->saved_data["n_heads"] = n_heads;
    }
    return attended;
  }

  static torch::autograd::variable_list backward(torch::autograd::AutogradContext* ctx,
                                                 torch::autograd::variable_list grads) {
    const auto saved = ctx->get_saved_variables();
    const auto &q = saved[0], &k = saved[1], &v = saved[2], &weights = saved[3];
    const int64_t n_heads = ctx->saved_data["n_heads"].toInt();
    const auto grad = grads[0].contiguous();
    const int64_t b = q.size(0), n = k.size(1), d = q.size(1);
    const kernels::AttentionShape shape{n, n_heads, d / n_heads};
    auto grad_q = torch::empty_like(q), grad_k = torch::empty_like(k), grad_v = torch::empty_like(v);
    const float *qp = q.data_ptr<float>(), *kp = k.data_ptr<float>(), *vp = v.data_ptr<float>(),
                *wp = weights.data_ptr<float>(), *gp = grad.data_ptr<float>();
    float *gq = grad_q.data_ptr<float>(), *gk = grad_k.data_ptr<float>(), *gv = grad_v.data_ptr<float>();
    at::parallel_for(0, b, 256, [&](int64_t begin, int64_t end) {
      kernels::masked_attention_backward(shape, begin, end, qp, kp, vp, wp, gp, gq, gk, gv);
    });
    return {grad_q, grad_k, grad_v, torch::Tensor(), torch::Tensor()};
  }
};

}  // namespace

torch::Tensor masked_attention(const torch::Tensor& q, const torch::Tensor& k, const torch::Tensor& v,
                               const torch::Tensor& alive, int64_t n_heads) {
  TORCH_CHECK(k.size(1) <= kernels::kMaxOther, "masked_attention: at most ", kernels::kMaxOther,
              " other aircraft, got ", k.size(1));
  return MaskedAttention::apply(q, k, v, alive, n_heads);
}

torch::Tensor masked_attention_reference(const torch::Tensor& q_flat, const torch::Tensor& k_flat,
                                         const torch::Tensor& v_flat, const torch::Tensor& ado_alive,
                                         int64_t n_heads) {
  const int64_t b = q_flat.size(0), n = k_flat.size(1), d = q_flat.size(1), dh = d / n_heads;
  const auto q = q_flat.view({b, 1, n_heads, dh});
  const auto k = k_flat.view({b, n, n_heads, dh});
  const auto v = v_flat.view({b, n, n_heads, dh});
  auto scores = (k * q).sum(-1) / std::sqrt(static_cast<double>(dh));  // [B, N, H]
  const auto alive = ado_alive.view({b, n, 1});
  // A finite fill (not -inf) keeps all-dead rows free of NaN; exp(-1e9) is exactly 0 in float,
  // and the multiply by `alive` zeroes the uniform weights of an all-dead row.
  scores = scores.masked_fill(alive.logical_not(), -1e9);
  const auto weights = torch::softmax(scores, 1) * alive.to(torch::kFloat32);
  return (weights.unsqueeze(-1) * v).sum(1).reshape({b, d});  // [B, H * dh]
}

AttentionEncoderImpl::AttentionEncoderImpl(const AttentionEncoderConfig& cfg) : cfg_(cfg) {
  TORCH_CHECK(cfg.d_ego > 0 && cfg.d_ado > 0 && cfg.n_other > 0, "AttentionEncoder: d_ego, d_ado, n_other must be > 0");
  TORCH_CHECK(cfg.n_heads > 0 && cfg.d_model % cfg.n_heads == 0, "AttentionEncoder: d_model (", cfg.d_model,
              ") must be a multiple of n_heads (", cfg.n_heads, ")");
  q_proj_ = register_module("q_proj", torch::nn::Linear(cfg.d_ego, cfg.d_model));
  k_proj_ = register_module("k_proj", torch::nn::Linear(cfg.d_ado, cfg.d_model));
  v_proj_ = register_module("v_proj", torch::nn::Linear(cfg.d_ado, cfg.d_model));
  out_proj_ = register_module("out_proj", torch::nn::Linear(cfg.d_model, cfg.d_model));
}

int64_t AttentionEncoderImpl::flops_per_sample() const {
  const int64_t d = cfg_.d_model, n = cfg_.n_other;
  return 2 * cfg_.d_ego * d            // query
         + 2 * 2 * n * cfg_.d_ado * d  // keys and values of every other aircraft
         + 2 * n * d                   // scores (all heads together span d)
         + 2 * n * d                   // weighted sum of the values
         + 2 * d * d;                  // output projection
}

torch::Tensor AttentionEncoderImpl::forward(const torch::Tensor& ego, const torch::Tensor& ado,
                                            const torch::Tensor& ado_alive) {
  check_tensor(ego, "ego", {-1, cfg_.d_ego}, torch::kFloat32);
  const int64_t b = ego.size(0), n = cfg_.n_other, h = cfg_.n_heads;
  check_tensor(ado, "ado", {b, n, cfg_.d_ado}, torch::kFloat32);
  check_tensor(ado_alive, "ado_alive", {b, n}, torch::kBool);

  const auto attended = masked_attention(dense_linear(ego, q_proj_), dense_linear(ado, k_proj_),
                                         dense_linear(ado, v_proj_), ado_alive, h);
  const auto any_alive = ado_alive.any(1, /*keepdim=*/true).to(torch::kFloat32);
  return dense_linear(attended, out_proj_) * any_alive;  // drop the output bias too: exact zeros if nobody is alive
}

DenseLayer dense_layer(const torch::nn::Linear& layer) {
  const auto w = layer->weight.detach().to(torch::kFloat32).contiguous();
  const auto b = layer->bias.detach().to(torch::kFloat32).contiguous();
  DenseLayer d;
  d.out = w.size(0);
  d.in = w.size(1);
  d.weight.assign(w.data_ptr<float>(), w.data_ptr<float>() + w.numel());
  d.bias.assign(b.data_ptr<float>(), b.data_ptr<float>() + b.numel());
  return d;
}

std::vector<torch::nn::Linear> linear_modules(const torch::nn::Sequential& mlp) {
  std::vector<torch::nn::Linear> layers;
  for (std::size_t i = 0; i < mlp->size(); ++i)
    if (auto linear = std::dynamic_pointer_cast<torch::nn::LinearImpl>(mlp->ptr(i))) layers.emplace_back(linear);
  return layers;
}

std::vector<DenseLayer> dense_layers(const torch::nn::Sequential& mlp) {
  std::vector<DenseLayer> layers;
  for (const auto& l : linear_modules(mlp)) layers.push_back(dense_layer(l));
  return layers;
}

AttentionMlpWeights encoder_weights(const AttentionEncoder& encoder, const ObsDims& dims) {
  AttentionMlpWeights w;
  w.d_ego = dims.d_ego;
  w.d_goal = dims.d_goal;
  w.d_ado = dims.d_ado;
  w.n_other = dims.n_other;
  w.d_task = dims.d_task;
  w.d_model = encoder->config().d_model;
  w.n_heads = encoder->config().n_heads;
  w.q = dense_layer(encoder->q_proj());
  w.k = dense_layer(encoder->k_proj());
  w.v = dense_layer(encoder->v_proj());
  w.out = dense_layer(encoder->out_proj());
  return w;
}

kernels::DenseView dense_view(const torch::nn::Linear& layer) {
  TORCH_CHECK(layer->weight.is_contiguous() && layer->bias.is_contiguous() &&
                  layer->weight.scalar_type() == torch::kFloat32,
              "dense_view: float contiguous parameters expected");
  return {layer->weight.size(0), layer->weight.size(1), layer->weight.data_ptr<float>(), layer->bias.data_ptr<float>()};
}

kernels::AttentionMlpTrainNet encoder_train_net(const AttentionEncoder& encoder, const ObsDims& dims, int64_t d_goal) {
  kernels::AttentionMlpTrainNet n;
  n.d_ego = dims.d_ego, n.d_goal = d_goal, n.d_ado = dims.d_ado, n.n_other = dims.n_other, n.d_task = dims.d_task;
  n.d_model = encoder->config().d_model, n.n_heads = encoder->config().n_heads;
  n.q = dense_view(encoder->q_proj());
  n.k = dense_view(encoder->k_proj());
  n.v = dense_view(encoder->v_proj());
  n.out = dense_view(encoder->out_proj());
  return n;
}

kernels::DenseGradView dense_grad_view(const torch::nn::Module& module, const std::vector<torch::Tensor>& grads,
                                       const torch::nn::Linear& layer) {
  const std::vector<torch::Tensor> params = module.parameters();
  TORCH_CHECK(grads.size() == params.size(), "dense_grad_view: one gradient per parameter expected");
  const auto grad_of = [&](const torch::Tensor& p) {
    for (std::size_t i = 0; i < params.size(); ++i)
      if (params[i].is_same(p)) {
        TORCH_CHECK(grads[i].is_contiguous() && grads[i].sizes() == p.sizes() &&
                        grads[i].scalar_type() == torch::kFloat32,
                    "dense_grad_view: gradient ", i, " must be float, contiguous, ", p.sizes());
        return grads[i].data_ptr<float>();
      }
    TORCH_CHECK(false, "dense_grad_view: a layer outside the module's parameters()");
    return static_cast<float*>(nullptr);
  };
  return {grad_of(layer->weight), grad_of(layer->bias)};
}

kernels::AttentionMlpTrainGrads encoder_train_grads(const torch::nn::Module& module,
                                                    const std::vector<torch::Tensor>& grads,
                                                    const AttentionEncoder& encoder) {
  kernels::AttentionMlpTrainGrads g;
  g.q = dense_grad_view(module, grads, encoder->q_proj());
  g.k = dense_grad_view(module, grads, encoder->k_proj());
  g.v = dense_grad_view(module, grads, encoder->v_proj());
  g.out = dense_grad_view(module, grads, encoder->out_proj());
  return g;
}

}  // namespace f16race::models
