#include "models/kernels/attention_mlp_train.hpp"

#include <Eigen/Core>
#include <algorithm>
#include <stdexcept>
#include <string>

#include "models/kernels/fixed_order_gemm.hpp"
#include "models/kernels/masked_attention.hpp"

namespace f16race::models::kernels {
namespace {

void grow(std::vector<float>& v, int64_t n) {
  if (static_cast<int64_t>(v.size()) < n) v.resize(static_cast<std::size_t>(n));
}

void transpose_into(const DenseView& l, std::vector<float>& wt) {
  grow(wt, l.out * l.in);
  transpose_weight(l.weight, l.out, l.in, wt.data());
}

// y [rows, out] (row stride ldy) = x [rows, in] (row stride ldx) W^T + b, with wt = W^T.
void forward_product(const DenseView& l, const float* wt, const float* x, int64_t ldx, int64_t rows, float* y,
                     int64_t ldy) {
  GemmArgs g;
  g.m = rows, g.n = l.out, g.k = l.in;
  g.a = x, g.a_row_stride = ldx;
  g.b = wt, g.b_row_stride = l.out;
  g.bias = l.bias;
  g.c = y, g.c_row_stride = ldy;
  fixed_order_gemm(g);
}

// dW [out, in] = dy^T x (one chain along the rows) and db = dy's column sums; dy [rows, out]
// contiguous, x [rows, in] with row stride ldx.
void weight_grads(const DenseView& l, const float* dy, const float* x, int64_t ldx, int64_t rows,
                  const DenseGradView& g) {
  GemmArgs a;
  a.m = l.out, a.n = l.in, a.k = rows;
  a.a = dy, a.a_row_stride = 1, a.a_col_stride = l.out;
  a.b = x, a.b_row_stride = ldx;
  a.c = g.weight, a.c_row_stride = l.in;
  fixed_order_gemm(a);
  column_sums(dy, rows, l.out, 0, l.out, g.bias);
}

// dx [rows, n] (row stride ldx) = dy W[:, col0 : col0 + n]: the input gradient of n of its columns.
void input_grads(const DenseView& l, const float* dy, int64_t rows, int64_t col0, int64_t n, float* dx,
                 int64_t ldx) {
  GemmArgs a;
  a.m = rows, a.n = n, a.k = l.out;
  a.a = dy, a.a_row_stride = l.out;
  a.b = l.weight + col0, a.b_row_stride = l.in;
  a.c = dx, a.c_row_stride = ldx;
  fixed_order_gemm(a);
}

// The rollout forward's tanh (attention_mlp_forward.cpp: Eigen's, elementwise), so both passes
// see the same activations.
void tanh_in_place(float* x, int64_t n) {
  Eigen::Map<Eigen::ArrayXf> a(x, n);
  a = a.tanh();
}

void check_dense(const DenseView& l, int64_t in, const std::string& name) {
  if (l.in != in || l.out <= 0 || l.weight == nullptr || l.bias == nullptr)
    throw std::invalid_argument("AttentionMlpTrain: layer " + name + " is [" + std::to_string(l.out) + ", " +
                                std::to_string(l.in) + "], expected input width " + std::to_string(in));
}

void check_mlp(const std::vector<DenseView>& layers, int64_t in, const std::string& name) {
  if (layers.empty()) throw std::invalid_argument("AttentionMlpTrain: " + name + " has no layer");
  for (std::size_t i = 0; i < layers.size(); ++i) {
    check_dense(layers[i], in, name + "." + std::to_string(i));
    in = layers[i].out;
  }
}

}  // namespace

struct AttentionMlpTrain::Impl {
  int64_t batch = 0;
  std::vector<float> x;                 // [B, d_ego + d_goal + d_model + d_task]: the MLPs' input
  std::vector<float> ado;               // [B * N, d_ado]
  std::unique_ptr<bool[]> alive;        // [B, N]
  int64_t alive_capacity = 0;
  std::vector<char> row_alive;          // [B]: anyone alive
  std::vector<float> q, k, v, weights, attended;  // the encoder's
  std::vector<std::vector<float>> actor_h, critic_h;  // hidden activations after tanh
  std::vector<float> wt_q, wt_k, wt_v, wt_o;
  std::vector<std::vector<float>> actor_wt, critic_wt;
  std::vector<float> denc, denc_critic, datt, dq, dk, dv, dh0, dh1;

  bool relu = false;  // the activation between the MLPs' layers (else tanh)

  void mlp_forward(const std::vector<DenseView>& layers, std::vector<std::vector<float>>& wt,
                   std::vector<std::vector<float>>& h, int64_t ldx, float* out);
  void mlp_backward(const std::vector<DenseView>& layers, const std::vector<std::vector<float>>& h, int64_t ldx,
                    const float* d_out, const std::vector<DenseGradView>& grads, int64_t enc0, int64_t d,
                    float* d_enc);
};

void AttentionMlpTrain::Impl::mlp_forward(const std::vector<DenseView>& layers, std::vector<std::vector<float>>& wt,
                                          std::vector<std::vector<float>>& h, int64_t ldx, float* out) {
  wt.resize(layers.size());
  h.resize(layers.size() - 1);
  const float* in = x.data();
  int64_t ld = ldx;
  for (std::size_t i = 0; i < layers.size(); ++i) {
    const bool last = i + 1 == layers.size();
    transpose_into(layers[i], wt[i]);
    float* dst = out;
    if (!last) {
      grow(h[i], batch * layers[i].out);
      dst = h[i].data();
    }
    forward_product(layers[i], wt[i].data(), in, ld, batch, dst, layers[i].out);
    if (!last && relu) {  // the rollout forward's max(x, 0)
      for (int64_t j = 0; j < batch * layers[i].out; ++j) dst[j] = std::max(dst[j], 0.0f);
    } else if (!last) {
      tanh_in_place(dst, batch * layers[i].out);
    }
    in = dst;
    ld = layers[i].out;
  }
}

// Every layer's weight and bias gradients from d_out (the last layer's output gradient), and the
// gradient of the input's encoder columns [enc0, enc0 + d) into d_enc [B, d].
void AttentionMlpTrain::Impl::mlp_backward(const std::vector<DenseView>& layers,
                                           const std::vector<std::vector<float>>& h, int64_t ldx,
                                           const float* d_out, const std::vector<DenseGradView>& grads, int64_t enc0,
                                           int64_t d, float* d_enc) {
  int64_t widest = 0;
  for (const auto& l : layers) widest = std::max(widest, l.in);
  grow(dh0, batch * widest);
  grow(dh1, batch * widest);
  const float* dy = d_out;
  for (std::size_t i = layers.size(); i-- > 0;) {
    const float* in = i == 0 ? x.data() : h[i - 1].data();
    weight_grads(layers[i], dy, in, i == 0 ? ldx : layers[i - 1].out, batch, grads[i]);
    if (i == 0) {
      input_grads(layers[0], dy, batch, enc0, d, d_enc, d);
      break;
    }
    float* dh = dy == dh0.data() ? dh1.data() : dh0.data();
    const int64_t width = layers[i].in;
    input_grads(layers[i], dy, batch, 0, width, dh, width);
    const float* y = h[i - 1].data();
    if (relu) {
      for (int64_t j = 0; j < batch * width; ++j) dh[j] = y[j] > 0.0f ? dh[j] : 0.0f;
    } else {
      for (int64_t j = 0; j < batch * width; ++j) dh[j] *= 1.0f - y[j] * y[j];  // tanh' = 1 - tanh^2
    }
    dy = dh;
  }
}

AttentionMlpTrain::AttentionMlpTrain() : impl_(std::make_unique<Impl>()) {}
AttentionMlpTrain::~AttentionMlpTrain() = default;

void AttentionMlpTrain::check(const AttentionMlpTrainNet& net) {
  if (net.d_ego <= 0 || net.d_ado <= 0 || net.n_other <= 0 || net.n_other > kMaxOther || net.d_goal < 0 ||
      net.d_task < 0 || net.n_heads <= 0 || net.d_model % net.n_heads != 0)
    throw std::invalid_argument("AttentionMlpTrain: sizes out of range (n_other " + std::to_string(net.n_other) +
                                ", d_model " + std::to_string(net.d_model) + ", n_heads " +
                                std::to_string(net.n_heads) + ")");
  check_dense(net.q, net.d_ego, "q");
  check_dense(net.k, net.d_ado, "k");
  check_dense(net.v, net.d_ado, "v");
  check_dense(net.out, net.d_model, "out");
  if (net.q.out != net.d_model || net.k.out != net.d_model || net.v.out != net.d_model || net.out.out != net.d_model)
    throw std::invalid_argument("AttentionMlpTrain: the projections must be d_model = " + std::to_string(net.d_model) +
                                " wide");
  const int64_t in = net.d_ego + net.d_goal + net.d_model + net.d_task;
  check_mlp(net.actor, in, "actor");
  if (!net.critic.empty()) {
    check_mlp(net.critic, in, "critic");
    if (net.critic.back().out != 1) throw std::invalid_argument("AttentionMlpTrain: the critic must end in one unit");
  }
}

void AttentionMlpTrain::forward(const AttentionMlpTrainNet& net, int64_t batch, const TrainRows& rows, float* mean,
                                float* value) {
  check(net);
  Impl& s = *impl_;
  const int64_t b = batch, n = net.n_other, d = net.d_model, da = net.d_ado;
  const int64_t enc0 = net.d_ego + net.d_goal, task0 = enc0 + d, dx = task0 + net.d_task;
  s.batch = b;
  s.relu = net.relu;
  grow(s.x, b * dx);
  grow(s.ado, b * n * da);
  if (s.alive_capacity < b * n) {
    s.alive = std::make_unique<bool[]>(static_cast<std::size_t>(b * n));
    s.alive_capacity = b * n;
  }
  s.row_alive.resize(static_cast<std::size_t>(b));
  for (int64_t r = 0; r < b; ++r) {  // gather the chunk's rows: [ego, goal, (encoded), task] and the others
    const int64_t src = rows.index[r];
    float* xr = s.x.data() + r * dx;
    std::copy_n(rows.ego + src * net.d_ego, net.d_ego, xr);
    std::copy_n(rows.goal + src * net.d_goal, net.d_goal, xr + net.d_ego);
    std::copy_n(rows.task + src * net.d_task, net.d_task, xr + task0);
    std::copy_n(rows.ado + src * n * da, n * da, s.ado.data() + r * n * da);
    bool any = false;
    for (int64_t j = 0; j < n; ++j) any = (s.alive[r * n + j] = rows.ado_alive[src * n + j]) || any;
    s.row_alive[r] = any ? 1 : 0;
  }
  grow(s.q, b * d);
  grow(s.k, b * n * d);
  grow(s.v, b * n * d);
  grow(s.weights, b * net.n_heads * n);
  grow(s.attended, b * d);
  transpose_into(net.q, s.wt_q);
  transpose_into(net.k, s.wt_k);
  transpose_into(net.v, s.wt_v);
  transpose_into(net.out, s.wt_o);
  forward_product(net.q, s.wt_q.data(), s.x.data(), dx, b, s.q.data(), d);
  forward_product(net.k, s.wt_k.data(), s.ado.data(), da, b * n, s.k.data(), d);
  forward_product(net.v, s.wt_v.data(), s.ado.data(), da, b * n, s.v.data(), d);
  const AttentionShape shape{n, net.n_heads, d / net.n_heads};
  masked_attention_forward(shape, 0, b, s.q.data(), s.k.data(), s.v.data(), s.alive.get(), s.weights.data(),
                           s.attended.data());
  forward_product(net.out, s.wt_o.data(), s.attended.data(), d, b, s.x.data() + enc0, dx);
  for (int64_t r = 0; r < b; ++r)  // nobody alive: exactly 0, the output bias dropped too
    if (!s.row_alive[r]) std::fill_n(s.x.data() + r * dx + enc0, d, 0.0f);
  s.mlp_forward(net.actor, s.actor_wt, s.actor_h, dx, mean);
  if (!net.critic.empty()) s.mlp_forward(net.critic, s.critic_wt, s.critic_h, dx, value);
}

void AttentionMlpTrain::backward(const AttentionMlpTrainNet& net, const float* d_mean, const float* d_value,
                                 const AttentionMlpTrainGrads& grads) {
  Impl& s = *impl_;
  const int64_t b = s.batch, n = net.n_other, d = net.d_model, da = net.d_ado;
  const int64_t enc0 = net.d_ego + net.d_goal, dx = enc0 + d + net.d_task;
  if (grads.actor.size() != net.actor.size() || grads.critic.size() != net.critic.size())
    throw std::invalid_argument("AttentionMlpTrain::backward: one gradient view per layer needed");
  grow(s.denc, b * d);
  grow(s.denc_critic, b * d);
  s.mlp_backward(net.actor, s.actor_h, dx, d_mean, grads.actor, enc0, d, s.denc.data());
  const bool value = !net.critic.empty();
  if (value) s.mlp_backward(net.critic, s.critic_h, dx, d_value, grads.critic, enc0, d, s.denc_critic.data());
  for (int64_t r = 0; r < b; ++r) {
    float* e = s.denc.data() + r * d;
    const float* c = s.denc_critic.data() + r * d;
    if (!s.row_alive[r]) std::fill_n(e, d, 0.0f);
    else if (value) for (int64_t j = 0; j < d; ++j) e[j] += c[j];
  }
  weight_grads(net.out, s.denc.data(), s.attended.data(), d, b, grads.out);
  grow(s.datt, b * d);
  input_grads(net.out, s.denc.data(), b, 0, d, s.datt.data(), d);
  grow(s.dq, b * d);
  grow(s.dk, b * n * d);
  grow(s.dv, b * n * d);
  const AttentionShape shape{n, net.n_heads, d / net.n_heads};
  masked_attention_backward(shape, 0, b, s.q.data(), s.k.data(), s.v.data(), s.weights.data(), s.datt.data(),
                            s.dq.data(), s.dk.data(), s.dv.data());
  weight_grads(net.q, s.dq.data(), s.x.data(), dx, b, grads.q);
  weight_grads(net.k, s.dk.data(), s.ado.data(), da, b * n, grads.k);
  weight_grads(net.v, s.dv.data(), s.ado.data(), da, b * n, grads.v);
}

}  // namespace f16race::models::kernels
