#pragma once
// The core of the attention encoder (models/attention_encoder.hpp) as plain loops: one query per
// sample, softmax over the alive other aircraft only, weighted sum of their values, per head.
// LibTorch composes it from ~10 elementwise ops on [B, N, H, dh] tensors, each allocating and
// streaming its own intermediate; here it is one pass, forward and backward, with no allocation.
// Used by the encoder's autograd function (training and LibTorch inference) and by
// AttentionMlpForward; compiled with the simulator's instruction-set flags (dh = 16 floats is one
// AVX-512 vector). Rows are independent, so any split of [0, B) over threads gives the same bits.
#include <cstdint>

namespace f16race::models::kernels {

constexpr int64_t kMaxOther = 64;  // the backward keeps one head's key gradients on the stack

struct AttentionShape {
  int64_t n_other = 0;  // N, keys and values per sample, at most kMaxOther
  int64_t n_heads = 0;  // H
  int64_t d_head = 0;   // dh; d_model = H * dh
};

// Rows [row_begin, row_end) of: q [B, H*dh], k and v [B, N, H*dh], alive [B, N] (true = attend).
// Writes weights [B, H, N] (0 for the dead; all 0 when nobody is alive) and attended [B, H*dh]
// (0 when nobody is alive). Scores are q.k / sqrt(dh).
void masked_attention_forward(const AttentionShape& s, int64_t row_begin, int64_t row_end, const float* q,
                              const float* k, const float* v, const bool* alive, float* weights, float* attended);

// Gradients of the forward's `attended` for rows [row_begin, row_end), given grad_attended
// [B, H*dh] and the forward's inputs and weights. Writes (overwrites) grad_q [B, H*dh],
// grad_k and grad_v [B, N, H*dh]; dead keys and values get 0.
void masked_attention_backward(const AttentionShape& s, int64_t row_begin, int64_t row_end, const float* q,
                               const float* k, const float* v, const float* weights, const float* grad_attended,
                               float* grad_q, float* grad_k, float* grad_v);

}  // namespace f16race::models::kernels
