#include "agents/gradient_step.hpp"

#include <algorithm>

#include "agents/concurrent_chunks.hpp"
#include "agents/optimizer_step.hpp"

namespace f16race::agents {
namespace {

// The union's gradient and terms from this replica's; false when the union has no unit.
bool mix_replicas(const std::vector<torch::Tensor>& params, const GradientStepOptions& o,
                  std::array<double, kMaxStepTerms>& terms) {
  const double w = o.replica_weight;
  if (o.mix == ReplicaMix::kShareWeighted) {
    std::vector<double> extra(static_cast<std::size_t>(o.n_terms));
    for (int q = 0; q < o.n_terms; ++q) extra[q] = terms[q] * w;
    sum_weighted_gradients(params, w, extra, *o.replicas);
    std::copy(extra.begin(), extra.end(), terms.begin());
    return true;
  }
  // The union's loss is a mean over its units: each replica's gradient weighs by its count of
  // them (exact for a mean loss), and the sum is divided by the union's count.
  std::vector<double> extra(static_cast<std::size_t>(o.n_terms) + 1);
  extra[0] = w;
  for (int q = 0; q < o.n_terms; ++q) extra[q + 1] = terms[q] * w;
  sum_weighted_gradients(params, w, extra, *o.replicas);
  if (extra[0] == 0.0) return false;  // no unit on any replica: no step anywhere
  for (auto& p : params) p.mutable_grad().div_(static_cast<float>(extra[0]));
  for (int q = 0; q < o.n_terms; ++q) terms[q] = extra[q + 1] / extra[0];
  return true;
}

}  // namespace

GradientStepResult gradient_step(torch::optim::Adam& optimizer, const std::vector<torch::Tensor>& params,
                                 std::vector<ChunkGradient>& chunks,
                                 const std::function<void(int64_t, ChunkGradient&)>& run,
                                 const GradientStepOptions& o) {
  GradientStepResult out;
  const int64_t n_chunks = static_cast<int64_t>(chunks.size());
  // Each chunk's gradient on its own (autograd::grad, nothing accumulated in place), then summed
  // in chunk order, which is what serial backward() calls accumulate.
  out.chunk_wait_s = run_chunks(n_chunks, [&](int64_t c) { run(c, chunks[static_cast<std::size_t>(c)]); });
  std::vector<const std::vector<torch::Tensor>*> chunk_grads;
  for (const ChunkGradient& k : chunks) {
    out.passes += k.grads.empty() ? 0 : 1;
    chunk_grads.push_back(&k.grads);
    for (std::size_t q = 0; q < out.terms.size(); ++q) out.terms[q] += k.weight * k.terms[q];
  }
  sum_chunk_gradients(params, chunk_grads, o.zero_unused);
  if (o.replicas && o.replicas->active() && !mix_replicas(params, o, out.terms)) return out;
  out.grad_norm = clip_and_adam_step(optimizer, o.max_grad_norm);
  out.stepped = true;
  return out;
}

}  // namespace f16race::agents
