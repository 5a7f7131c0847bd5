// hl.inference eigen: EsAgent's action values on the Eigen kernels follow the online critic
// through everything that moves its weights (gradient steps, a load, the weight average, a write
// through critic()), agreeing with the LibTorch path to float rounding for every variant; a
// per_axis critic stays on LibTorch.
#include <gtest/gtest.h>
#include <torch/torch.h>

#include <algorithm>
#include <filesystem>
#include <string>

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
    // Gradient steps (and the average taken after them).
    torch_path.update(batch);
    eigen_path.update(batch);
    torch_path.add_to_average();
    eigen_path.add_to_average();
    const torch::Tensor stepped = eigen_path.q_values(obs);
    EXPECT_GT((stepped - before).abs().max().item<double>(), 1e-3) << name << ": the steps moved nothing";
    expect_close(stepped, torch_path.q_values(obs), name + " after update");
    // A second update, then acting with the average of the two.
    torch_path.update(batch);
    eigen_path.update(batch);
    torch_path.add_to_average();
    eigen_path.add_to_average();
    torch_path.act_with_average();
    eigen_path.act_with_average();
    expect_close(eigen_path.q_values(obs), torch_path.q_values(obs), name + " with the average");
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

TEST(EsInference, PerAxisCriticStaysOnLibTorch) {
  const models::ObsDims dims{4, 2, 2, 2};
  EsConfig cfg = replica_es_config(EsVariant::kEsD2, dims);
  cfg.per_axis_critic = true;
  torch::manual_seed(6);
  EsAgent agent(cfg);
  const models::HlObs obs = models::flatten2(es_batch(dims, 0, 8).obs);
  torch::NoGradGuard no_grad;
  EXPECT_TRUE(torch::equal(agent.q_values(obs), agent.critic()(agent.normalizer()->normalize(obs, false)).q));
}

}  // namespace
}  // namespace f16race::agents
