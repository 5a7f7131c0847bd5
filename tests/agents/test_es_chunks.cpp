// Expected SARSA's gradient steps in concurrent chunks (EsConfig::minibatch_chunks): the same
// update as one pass, to float summation order, for every variant; the same bits at 1 and 2
// threads. Uneven chunks (8 teams in 3) and teams without an active aircraft included.
#include <gtest/gtest.h>
#include <omp.h>
#include <torch/torch.h>

#include <algorithm>
#include <cmath>
#include <memory>

#include "agents/expected_sarsa.hpp"
#include "support/replica_samples.hpp"

namespace f16race::agents {
namespace {

using test_support::es_batch;
using test_support::max_abs_diff;
using test_support::replica_es_config;
using test_support::same_bits;

TEST(EsChunks, ChunkedStepsGiveTheSameUpdateForEveryVariant) {
  const models::ObsDims dims{4, 2, 2, 2};
  const int threads = omp_get_max_threads();
  for (EsVariant v : {EsVariant::kEs, EsVariant::kEsD1, EsVariant::kEsD2, EsVariant::kEsD3}) {
    EsConfig cfg = replica_es_config(v, dims);
    EsBatch batch = es_batch(dims, 0, 8);
    batch.active[2].fill_(false);  // a team none of whose aircraft took the decision
    torch::manual_seed(6);
    EsAgent one(cfg);
    const EsStats one_stats = one.update(batch);
    cfg.minibatch_chunks = 3;
    EsAgent* first = nullptr;
    std::unique_ptr<EsAgent> at[2];
    for (int t : {1, 2}) {
      omp_set_num_threads(t);
      torch::manual_seed(6);
      at[t - 1] = std::make_unique<EsAgent>(cfg);
      const EsStats s = at[t - 1]->update(batch);
      EXPECT_EQ(s.grad_steps, one_stats.grad_steps);
      EXPECT_EQ(s.train_passes, 3 * one_stats.grad_steps) << es_variant_name(v);
      // bench train's floor prices the passes at their rows' alive share: every team once an epoch.
      const int64_t alive = batch.obs.ado_alive.sum().item<int64_t>();
      ASSERT_GT(alive, 0);
      ASSERT_LT(alive, batch.obs.ado_alive.numel());
      EXPECT_EQ(s.train_alive, cfg.n_epochs * alive) << es_variant_name(v);
      EXPECT_EQ(s.forward_alive, alive + batch.next_obs.ado_alive.sum().item<int64_t>()) << es_variant_name(v);
      EXPECT_NEAR(s.loss, one_stats.loss, 1e-5 * std::max(1.0, std::abs(one_stats.loss))) << es_variant_name(v);
      if (first == nullptr) first = at[t - 1].get();
    }
    omp_set_num_threads(threads);
    // lr 1e-2 over three steps moves weights ~1e-2: a wrongly weighted chunk would show.
    EXPECT_LT(max_abs_diff(*one.critic(), *first->critic()), 2e-5) << es_variant_name(v);
    EXPECT_TRUE(same_bits(*at[0]->critic(), *at[1]->critic())) << es_variant_name(v) << ": 1 vs 2 threads";
  }
}

}  // namespace
}  // namespace f16race::agents
