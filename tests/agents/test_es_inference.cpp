// EsConfig::eigen_inference: EsAgent's action values on the Eigen kernels follow the online critic
// through everything that moves its weights (gradient steps, a load, a write through critic()),
// agreeing with the LibTorch path to float rounding for every variant.
#include <gtest/gtest.h>
#include <torch/torch.h>

#include <algorithm>
#include <filesystem>
#include <string>
#include <vector>

#include "agents/expected_sarsa.hpp"
#include "support/replica_samples.hpp"

namespace f16race::agents {
namespace {

using test_support::es_batch;
using test_support::replica_es_config;

// Values of the same order as the critic's; float rounding in another summation order.
void expect_close(const torch::Tensor& got, const torch::Tensor& want, const std::string& at) {
  const double scale = std::max(1.0, want.abs().max().item<double>());
  EXPECT_LT((got - want).abs().max().item<double>(), 1e-4 * scale) << at;
}

TEST(EsInference, EigenValuesFollowEveryWeightChange) {
  const models::ObsDims dims{4, 2, 2, 2};
  const std::string dir = (std::filesystem::temp_directory_path() / "f16race_es_inference").string();
  std::filesystem::create_directories(dir);
  for (EsVariant v : {EsVariant::kEs, EsVariant::kEsD1, EsVariant::kEsD2, EsVariant::kEsD3}) {
    EsConfig cfg = replica_es_config(v, dims);
    cfg.eigen_inference = false;
    torch::manual_seed(6);
    EsAgent torch_path(cfg);
    cfg.eigen_inference = true;
    torch::manual_seed(6);
    EsAgent eigen_path(cfg);
    const EsBatch batch = es_batch(dims, 0, 8);
    const models::HlObs obs = models::flatten2(batch.obs);
    const std::string name = es_variant_name(v);
    const torch::Tensor before = eigen_path.q_values(obs);
    expect_close(before, torch_path.q_values(obs), name + " fresh");
    // Gradient steps.
    torch_path.update(batch);
    eigen_path.update(batch);
    const torch::Tensor stepped = eigen_path.q_values(obs);
    EXPECT_GT((stepped - before).abs().max().item<double>(), 1e-3) << name << ": the steps moved nothing";
    expect_close(stepped, torch_path.q_values(obs), name + " after update");
    torch_path.update(batch);
    eigen_path.update(batch);
    expect_close(eigen_path.q_values(obs), torch_path.q_values(obs), name + " after a second update");
    // A load of another state: the fresh agent's.
    const std::string file = dir + "/" + name + ".pt";
    torch::manual_seed(7);
    EsAgent other(cfg);
    other.save(file);
    eigen_path.load(file);
    torch_path.load(file);
    expect_close(eigen_path.q_values(obs), torch_path.q_values(obs), name + " after a load");
    // A write through the module itself.
    {
      torch::NoGradGuard no_grad;
      for (auto& p : eigen_path.critic()->parameters()) p.mul_(0.5);
      for (auto& p : torch_path.critic()->parameters()) p.mul_(0.5);
    }
    expect_close(eigen_path.q_values(obs), torch_path.q_values(obs), name + " after an in-place write");
  }
  std::filesystem::remove_all(dir);
}

// The trainer's decisions read the rows each critic flies in place (EsAgent::act(obs, rows, ...)):
// the same action values and bins, bit for bit, as acting on a gathered copy of those rows, on both
// paths, with statistics that are not the identity (an update absorbed a batch first), rows in any
// order, one repeated; a row outside the batch is refused.
TEST(EsInference, ActingOnPickedRowsIsActingOnTheirCopy) {
  const models::ObsDims dims{4, 2, 2, 2};
  for (bool eigen : {false, true}) {
    for (EsVariant v : {EsVariant::kEs, EsVariant::kEsD2, EsVariant::kEsD3}) {
      EsConfig cfg = replica_es_config(v, dims);
      cfg.eigen_inference = eigen;
      torch::manual_seed(6);
      EsAgent agent(cfg);
      const EsBatch batch = es_batch(dims, 0, 8);
      agent.update(batch);
      const models::HlObs obs = models::flatten2(batch.next_obs);  // 24 rows the statistics did not see
      const auto rows = torch::tensor(std::vector<int64_t>{17, 3, 3, 0, 23, 9, 10, 11}, torch::kInt64);
      const std::string at = std::string(eigen ? "eigen " : "torch ") + es_variant_name(v);
      const auto want = agent.q_values(models::index_rows(obs, rows));
      EXPECT_TRUE(torch::equal(agent.q_values(obs, rows), want)) << at;
      auto g0 = models::make_generator(5), g1 = models::make_generator(5);
      const EsAction a = agent.act(models::index_rows(obs, rows), 0.5, g0);
      const EsAction b = agent.act(obs, rows, 0.5, g1);
      EXPECT_TRUE(torch::equal(a.bins, b.bins)) << at;
      EXPECT_TRUE(torch::equal(a.q, b.q)) << at;
      EXPECT_THROW(agent.q_values(obs, torch::tensor(std::vector<int64_t>{0, 24}, torch::kInt64)), c10::Error) << at;
      EXPECT_THROW(agent.q_values(obs, torch::tensor(std::vector<int64_t>{-1}, torch::kInt64)), c10::Error) << at;
    }
  }
}

}  // namespace
}  // namespace f16race::agents
