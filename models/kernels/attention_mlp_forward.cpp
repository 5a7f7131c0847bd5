#include "models/kernels/attention_mlp_forward.hpp"

#include "models/kernels/fixed_order_gemm.hpp"
#include "models/kernels/masked_attention.hpp"

#include <omp.h>

#include <Eigen/Core>
#include <algorithm>
#include <cmath>
#include <stdexcept>
#include <string>

namespace f16race::models {
namespace {

using RowMatrixF = Eigen::Matrix<float, Eigen::Dynamic, Eigen::Dynamic, Eigen::RowMajor>;

// A layer as the fixed-order product reads it (the training path's kernels, dense_linear).
struct Dense {
  int64_t out = 0, in = 0;
  std::vector<float> weight_t;  // [in, out]: W transposed, the product's B
  std::vector<float> bias;      // [out]
};

// y [rows, l.out] (row stride ldy) = x [rows, l.in] (row stride ldx) W^T + b.
void dense_product(const Dense& l, const float* x, int64_t ldx, int64_t rows, float* y, int64_t ldy) {
  kernels::GemmArgs g;
  g.m = rows;
  g.n = l.out;
  g.k = l.in;
  g.a = x;
  g.a_row_stride = ldx;
  g.b = l.weight_t.data();
  g.b_row_stride = l.out;
  g.bias = l.bias.data();
  g.c = y;
  g.c_row_stride = ldy;
  kernels::fixed_order_gemm(g);
}

void check_layer(const DenseLayer& l, int64_t in, const std::string& name) {
  if (l.in != in || l.out <= 0 || static_cast<int64_t>(l.weight.size()) != l.out * l.in ||
      static_cast<int64_t>(l.bias.size()) != l.out)
    throw std::invalid_argument("AttentionMlpForward: layer " + name + " is [" + std::to_string(l.out) + ", " +
                                std::to_string(l.in) + "] with " + std::to_string(l.weight.size()) + " weights and " +
                                std::to_string(l.bias.size()) + " biases, expected input width " + std::to_string(in));
}

int64_t check_mlp(const std::vector<DenseLayer>& layers, int64_t in, const std::string& name) {
  if (layers.empty()) throw std::invalid_argument("AttentionMlpForward: " + name + " has no layer");
  for (std::size_t i = 0; i < layers.size(); ++i) {
    check_layer(layers[i], in, name + "." + std::to_string(i));
    in = layers[i].out;
  }
  return in;
}

Dense dense_of(const DenseLayer& l) {
  Dense d{l.out, l.in, std::vector<float>(static_cast<std::size_t>(l.out * l.in)), l.bias};
  kernels::transpose_weight(l.weight.data(), l.out, l.in, d.weight_t.data());
  return d;
}

std::vector<Dense> dense_of(const std::vector<DenseLayer>& layers) {
  std::vector<Dense> d;
  for (const auto& l : layers) d.push_back(dense_of(l));
  return d;
}

// One thread's buffers for a block of rows, reused from call to call.
struct Scratch {
  RowMatrixF q_, k_, v_, attended_, encoded_, x_, h0_, h1_, y_;  // [rows, *] or [rows * n_other, *]
  std::vector<float> weights_;                                    // [rows, H, n_other]

  void mlp(const std::vector<Dense>& layers, Activation activation, RowMatrixF* result) {
    const RowMatrixF* in = &x_;
    RowMatrixF* bufs[2] = {&h0_, &h1_};
    for (std::size_t i = 0; i < layers.size(); ++i) {
      const bool last = i + 1 == layers.size();
      RowMatrixF* dst = last ? result : bufs[i % 2];
      dst->resize(in->rows(), layers[i].out);
      dense_product(layers[i], in->data(), in->cols(), in->rows(), dst->data(), dst->cols());
      if (!last && activation == Activation::kTanh) *dst = dst->array().tanh().matrix();
      if (!last && activation == Activation::kRelu) *dst = dst->cwiseMax(0.0f);
      in = dst;
    }
  }
};

// Rows are computed in blocks of this many, whatever the thread count: a block's arithmetic (and
// so every output bit) depends only on its rows, and the blocks are the same at any thread count.
constexpr int64_t kBlockRows = 32;

// Rows [lo, lo + rows): what PpoAgent::act's torch ops compute, operation for operation in float
// (mean + noise * std; z = (action - mean) * inv_std; -0.5 z z - log_std - log(2 pi) / 2, summed
// over the action as LibTorch sums 4 floats: in order). A draw of 4 actions per row is held equal to
// those ops bit for bit by tests/models/test_attention_mlp_forward. No fused multiply-adds: GCC contracts
// a + b * c in C++ by default, and LibTorch rounds the product and the sum apart.
__attribute__((optimize("fp-contract=off"))) void sample_rows(const GaussianDraw& d, int64_t lo, int64_t rows, int64_t a, const float* mean) {
  const float half_log_2pi = static_cast<float>(0.5 * std::log(2.0 * M_PI));
  for (int64_t i = lo; i < lo + rows; ++i) {
    float total = 0.0f;
    for (int64_t j = 0; j < a; ++j) {
      const float m = mean[i * a + j];
      const float spread = d.noise[i * a + j] * d.std[j];
      const float act = m + spread;
      d.action[i * a + j] = act;
      const float z = (act - m) * d.inv_std[j];
      const float term = ((-0.5f * z) * z - d.log_std[j]) - half_log_2pi;
      total = j == 0 ? term : total + term;
    }
    d.log_prob[i] = total;
  }
}

}  // namespace

struct AttentionMlpForward::Impl {
  int64_t d_ego = 0, d_goal = 0, d_ado = 0, n_other = 0, d_task = 0, d_model = 0, n_heads = 0;
  Dense q, k, v, out;
  std::vector<Dense> mlp, value_mlp;
  Activation activation = Activation::kTanh;
  std::vector<Scratch> scratch;  // one per OpenMP thread

  void forward_block(Scratch& m, int64_t b, const float* ego, const float* goal, const float* ado,
                     const bool* ado_alive, const float* task, float* mean, float* value) const;
};

AttentionMlpForward::AttentionMlpForward() = default;
AttentionMlpForward::~AttentionMlpForward() = default;

bool AttentionMlpForward::ready() const { return impl_ != nullptr; }

void AttentionMlpForward::set_weights(const AttentionMlpWeights& w) {
  if (w.n_heads <= 0 || w.d_model % w.n_heads != 0 || w.n_other <= 0 || w.n_other > kernels::kMaxOther)
    throw std::invalid_argument("AttentionMlpForward: d_model must be a multiple of n_heads > 0, 0 < n_other <= " +
                                std::to_string(kernels::kMaxOther));
  check_layer(w.q, w.d_ego, "q");
  check_layer(w.k, w.d_ado, "k");
  check_layer(w.v, w.d_ado, "v");
  check_layer(w.out, w.d_model, "out");
  if (w.q.out != w.d_model || w.k.out != w.d_model || w.v.out != w.d_model || w.out.out != w.d_model)
    throw std::invalid_argument("AttentionMlpForward: attention projections must be d_model wide");
  const int64_t in = w.d_ego + w.d_goal + w.d_model + w.d_task;
  check_mlp(w.mlp, in, "mlp");
  if (!w.value_mlp.empty() && check_mlp(w.value_mlp, in, "value_mlp") != 1)
    throw std::invalid_argument("AttentionMlpForward: value_mlp must end in 1 unit");
  auto impl = impl_ ? std::move(impl_) : std::make_unique<Impl>();  // keeps the scratch of an earlier copy
  impl->d_ego = w.d_ego;
  impl->d_goal = w.d_goal;
  impl->d_ado = w.d_ado;
  impl->n_other = w.n_other;
  impl->d_task = w.d_task;
  impl->d_model = w.d_model;
  impl->n_heads = w.n_heads;
  impl->q = dense_of(w.q);
  impl->k = dense_of(w.k);
  impl->v = dense_of(w.v);
  impl->out = dense_of(w.out);
  impl->mlp = dense_of(w.mlp);
  impl->value_mlp = w.value_mlp.empty() ? std::vector<Dense>() : dense_of(w.value_mlp);
  impl->activation = w.activation;
  impl_ = std::move(impl);
}

void AttentionMlpForward::forward(int64_t batch, const float* ego, const float* goal, const float* ado,
                             const bool* ado_alive, const float* task, float* mean, float* value,
                             const GaussianDraw* draw) {
  run_blocks(batch, nullptr, ego, goal, ado, ado_alive, task, mean, value, draw);
}

void AttentionMlpForward::forward(int64_t batch, const LlRawRows& raw, float* mean, float* value, const GaussianDraw* draw) {
  run_blocks(batch, &raw, raw.ego_out, raw.goal_out, raw.ado_out, raw.ado_alive_out, raw.task_out, mean, value, draw);
}

namespace {
// Rows [lo, lo + rows) of `raw` normalised into its outputs.
void normalize_block(const LlRawRows& raw, int64_t n_other, int64_t lo, int64_t rows) {
  const int64_t de = raw.ego_norm.d, dg = raw.goal_norm.d, da = raw.ado_norm.d, dt = raw.task_norm.d;
  for (int64_t i = lo; i < lo + rows; ++i) {
    const int64_t src = raw.index != nullptr ? raw.index[i] : i;
    kernels::normalize_row(raw.ego_norm, raw.ego + src * de, true, raw.ego_out + i * de);
    kernels::normalize_row(raw.goal_norm, raw.goal + src * dg, true, raw.goal_out + i * dg);
    for (int64_t j = 0; j < n_other; ++j) {
      const bool alive = raw.ado_alive[src * n_other + j];
      raw.ado_alive_out[i * n_other + j] = alive;
      kernels::normalize_row(raw.ado_norm, raw.ado + (src * n_other + j) * da, alive,
                             raw.ado_out + (i * n_other + j) * da);
    }
    kernels::normalize_row(raw.task_norm, raw.task + src * dt, true, raw.task_out + i * dt);
  }
}
}  // namespace

void AttentionMlpForward::run_blocks(int64_t batch, const LlRawRows* raw, const float* ego, const float* goal,
                                const float* ado, const bool* ado_alive, const float* task, float* mean, float* value,
                                const GaussianDraw* draw) {
  if (!impl_) throw std::logic_error("AttentionMlpForward::forward before set_weights");
  Impl& m = *impl_;
  if (raw != nullptr && (raw->ego_norm.d != m.d_ego || raw->goal_norm.d != m.d_goal || raw->ado_norm.d != m.d_ado ||
                         raw->task_norm.d != m.d_task))
    throw std::invalid_argument("AttentionMlpForward::forward: the normalisation terms' widths are not the network's inputs'");
  const int64_t n_blocks = (batch + kBlockRows - 1) / kBlockRows;
  const int threads = static_cast<int>(std::min<int64_t>(omp_get_max_threads(), n_blocks));
  if (static_cast<int>(m.scratch.size()) < std::max(threads, 1)) m.scratch.resize(static_cast<std::size_t>(std::max(threads, 1)));
  const int64_t n = m.n_other, a = m.mlp.back().out;
  auto block = [&](int64_t k, Scratch& sc) {
    const int64_t lo = k * kBlockRows, rows = std::min(kBlockRows, batch - lo);
    if (raw != nullptr) normalize_block(*raw, n, lo, rows);
    m.forward_block(sc, rows, ego + lo * m.d_ego, goal + lo * m.d_goal, ado + lo * n * m.d_ado, ado_alive + lo * n,
                    task + lo * m.d_task, mean + lo * a, value != nullptr ? value + lo : nullptr);
    if (draw != nullptr) sample_rows(*draw, lo, rows, a, mean);
  };
  if (threads <= 1) {
    for (int64_t k = 0; k < n_blocks; ++k) block(k, m.scratch[0]);
    return;
  }
  // Dynamic: a static schedule cuts an odd block count unevenly (a 66-row call was rows 0-63 on one
  // thread and 64-65 on the other); blocks taken one at a time make the LL forward ~8 % faster over
  // calls of 20-420 rows at 2 threads (the same blocks, so the same bits).
#pragma omp parallel for num_threads(threads) schedule(dynamic, 1)
  for (int64_t k = 0; k < n_blocks; ++k) block(k, m.scratch[static_cast<std::size_t>(omp_get_thread_num())]);
}

void AttentionMlpForward::Impl::forward_block(Scratch& m, int64_t b, const float* ego, const float* goal, const float* ado,
                                         const bool* ado_alive, const float* task, float* mean, float* value) const {
  const int64_t n = n_other, d = d_model, h = n_heads;
  using CMap = Eigen::Map<const RowMatrixF>;
  m.q_.resize(b, d);
  dense_product(this->q, ego, d_ego, b, m.q_.data(), d);
  m.k_.resize(b * n, d);
  dense_product(this->k, ado, d_ado, b * n, m.k_.data(), d);
  m.v_.resize(b * n, d);
  dense_product(this->v, ado, d_ado, b * n, m.v_.data(), d);

  // The attention core is the training path's kernel; a sample with nobody alive encodes to zeros.
  m.attended_.resize(b, d);
  m.weights_.resize(static_cast<std::size_t>(b * h * n));
  kernels::masked_attention_forward(kernels::AttentionShape{n, h, d / h}, 0, b, m.q_.data(), m.k_.data(),
                                    m.v_.data(), ado_alive, m.weights_.data(), m.attended_.data());
  m.encoded_.resize(b, d);
  dense_product(out, m.attended_.data(), d, b, m.encoded_.data(), d);
  for (int64_t i = 0; i < b; ++i) {
    bool any = false;
    for (int64_t j = 0; j < n; ++j) any = any || ado_alive[i * n + j];
    if (!any) m.encoded_.row(i).setZero();
  }

  // [ego, goal, encoded, task], the order of LlActorCritic's torch::cat.
  m.x_.resize(b, d_ego + d_goal + d + d_task);
  m.x_.leftCols(d_ego) = CMap(ego, b, d_ego);
  m.x_.middleCols(d_ego, d_goal) = CMap(goal, b, d_goal);
  m.x_.middleCols(d_ego + d_goal, d) = m.encoded_;
  m.x_.rightCols(d_task) = CMap(task, b, d_task);

  m.mlp(mlp, activation, &m.y_);
  Eigen::Map<RowMatrixF>(mean, b, m.y_.cols()) = m.y_;
  if (value_mlp.empty() || value == nullptr) return;
  m.mlp(value_mlp, activation, &m.y_);
  Eigen::Map<Eigen::VectorXf>(value, b) = m.y_.col(0);
}

}  // namespace f16race::models
