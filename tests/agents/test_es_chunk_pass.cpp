// Expected SARSA's ES+D2 and ES+D3 gradient steps through the fused training pass
// (agents/es_chunk_pass.hpp) against the same steps through LibTorch's autograd
// (EsConfig::fused_training false, the oracle): chunked minibatches, a team with no active
// aircraft, dead other aircraft; the pass moves every weight as autograd does, to float rounding.
#include <gtest/gtest.h>
#include <torch/torch.h>

#include <algorithm>
#include <cmath>
#include <vector>

#include "agents/expected_sarsa.hpp"
#include "support/replica_samples.hpp"

namespace f16race::agents {
namespace {

TEST(EsChunkPass, FusedStepsEqualTheAutogradStepsForTheTeamLosses) {
  const models::ObsDims dims{4, 2, 2, 2};
  for (EsVariant v : {EsVariant::kEsD2, EsVariant::kEsD3}) {
    EsConfig cfg = test_support::replica_es_config(v, dims);
    cfg.minibatch_chunks = 3;
    EsBatch batch = test_support::es_batch(dims, 0, 8);
    batch.active[2].fill_(false);  // a team none of whose aircraft took the decision
    std::vector<EsStats> stats;
    std::vector<std::unique_ptr<EsAgent>> agents;
    std::vector<torch::Tensor> initial;
    for (bool fused : {true, false}) {
      cfg.fused_training = fused;
      torch::manual_seed(8);
      agents.push_back(std::make_unique<EsAgent>(cfg));
      if (fused)
        for (const auto& p : agents.back()->critic()->parameters()) initial.push_back(p.detach().clone());
      stats.push_back(agents.back()->update(batch));
      stats.push_back(agents.back()->update(batch));
    }
    const char* name = es_variant_name(v);
    EXPECT_EQ(stats[1].train_passes, stats[3].train_passes) << name;
    EXPECT_NEAR(stats[1].loss, stats[3].loss, 1e-5 * std::max(1.0, std::abs(stats[3].loss))) << name;
    EXPECT_NEAR(stats[1].q_mean, stats[3].q_mean, 1e-5 * std::max(1.0, std::abs(stats[3].q_mean))) << name;
    // lr 1e-2, six steps: weights move ~1e-2; the paths differ in float rounding only.
    EXPECT_LT(test_support::max_abs_diff(*agents[0]->critic(), *agents[1]->critic()), 2e-5) << name;
    std::size_t i = 0;
    for (const auto& item : agents[0]->critic()->named_parameters()) {
      const double moved = (item.value() - initial[i++]).abs().max().item<double>();
      if (item.key() != "encoder.k_proj.bias") {  // the softmax cancels the key bias
        EXPECT_GT(moved, 1e-4) << name << " " << item.key();
      }
    }
  }
}

}  // namespace
}  // namespace f16race::agents
