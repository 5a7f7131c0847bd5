// TorchScript export: the saved modules, loaded back with torch::jit::load, answer exactly like
// the in-process networks (all HL heads: joint, decoupled, distributional, on one critic or one per
// goal axis; normalisation on and off); bad inputs are refused by name; a missing or mismatched run is refused.
#include <gtest/gtest.h>
#include <yaml-cpp/yaml.h>

#include <filesystem>
#include <fstream>

#include "export/torchscript_export.hpp"
#include "io/yaml_config.hpp"
#include "train/run_policy.hpp"
#include "train/trainer.hpp"

namespace f16race::torchscript {
namespace {

namespace fs = std::filesystem;

train::TrainConfig tiny_config(const std::string& agent, bool normalize = true) {
  YAML::Node root = YAML::Load(R"(
config_version: 1  # the tiny runs these tests were written for: version 1's defaults
race: {n_env: 2, team_size: 2, time_limit_s: 10.0, dt_hl_s: 1.6, track: {n_waypoints: 5}}
ll: {n_steps: 8, n_minibatches: 2, n_epochs: 1, hidden: [8, 8, 8], d_model: 8, n_heads: 2, init_log_std: -0.7}
hl: {hidden: [8, 8], d_model: 8, n_heads: 2, n_atoms: 11, n_steps_per_update: 1}
train: {total_env_steps: 100, ll_phase_updates: 1, hl_phase_updates: 1}
)");
  io::apply_override(root, "hl.agent=" + agent);
  train::TrainConfig cfg = train::read_train_config(root, "test");
  cfg.hl.normalize_obs = normalize;  // not a YAML key: the library default is always on
  cfg.ll.normalize_obs = normalize;
  return cfg;
}

// Untrained networks whose normalisers have seen shifted data, so normalisation matters.
train::RunPolicy policy_with_stats(const std::string& agent, bool normalize = true) {
  train::RunPolicy p = train::untrained_policy(tiny_config(agent, normalize), 7);
  const ExampleObs x = random_example_obs(p.dims, 64, 99, 3.0);
  const auto shift = [](const torch::Tensor& t) { return t * 2.0 + 1.5; };
  p.hl->normalizer()->normalize(models::HlObs{shift(x.ego), x.prev_action, shift(x.ado), x.ado_alive, shift(x.task)}, true);
  p.ll->normalize(models::LlObs{shift(x.ego), shift(x.goal), shift(x.ado), x.ado_alive, shift(x.task)}, true);
  return p;
}

torch::jit::Module round_trip(const torch::jit::Module& m, const std::string& name) {
  const std::string path = (fs::temp_directory_path() / ("f16race_export_" + name + ".pt")).string();
  m.save(path);
  return torch::jit::load(path);
}

double diff(const torch::Tensor& a, const torch::Tensor& b) { return (a - b).abs().max().item<double>(); }

class ExportVariants : public ::testing::TestWithParam<std::tuple<std::string, bool>> {};

TEST_P(ExportVariants, LoadedModulesMatchTheInProcessNetworks) {
  const auto& [agent, normalize] = GetParam();
  train::RunPolicy p = policy_with_stats(agent, normalize);
  const std::string tag = agent + (normalize ? "" : "_raw");  // tests run in parallel: own files
  torch::jit::Module hl = round_trip(make_hl_module(p), "hl_" + tag);
  torch::jit::Module ll = round_trip(make_ll_module(p), "ll_" + tag);
  for (std::int64_t batch : {1, 37}) {
    const ExampleObs x = random_example_obs(p.dims, batch, 1000 + batch);
    const HlReference hr = hl_reference(p, x);
    const LlReference lr = ll_reference(p, x);
    const auto ho = hl.forward({x.ego, x.prev_action, x.ado, x.ado_alive, x.task}).toGenericDict();
    const auto lo = ll.forward({x.ego, x.goal, x.ado, x.ado_alive, x.task}).toGenericDict();
    ExportReport bins;
    compare_bins(hr.q, hr.bins, ho.at("bins").toTensor(), &bins);
    EXPECT_TRUE(bins.bins_equal) << agent;  // every differing decision is a tie of two bins' Q
    EXPECT_LE(bins.bin_ties, bins.bin_decisions / 10) << agent;
    EXPECT_LT(diff(ho.at("q").toTensor(), hr.q), 1e-5) << agent;
    const bool d3 = agent.rfind("es_d3", 0) == 0;
    EXPECT_EQ(ho.contains("probs"), d3);
    if (d3) {
      EXPECT_LT(diff(ho.at("probs").toTensor(), hr.probs), 1e-5);
      EXPECT_NEAR(ho.at("probs").toTensor().sum(-1).min().item<double>(), 1.0, 1e-5);
    }
    EXPECT_LT(diff(lo.at("mean").toTensor(), lr.mean), 1e-5);
    EXPECT_LT(diff(lo.at("value").toTensor(), lr.value), 1e-5);
    EXPECT_LT(diff(lo.at("log_std").toTensor(), lr.log_std), 1e-7);
    EXPECT_NEAR(lo.at("log_std").toTensor()[0][0].item<double>(), -0.7, 1e-6);
    EXPECT_TRUE(lo.at("action").toTensor().equal(lo.at("mean").toTensor().clamp(-1.0, 1.0)));
    EXPECT_LT(diff(lo.at("action").toTensor(), lr.mean.clamp(-1.0, 1.0)), 1e-5);
    // The encoder's all-dead branch was exercised (sample 0 sees nobody).
    EXPECT_FALSE(x.ado_alive[0].any().item<bool>());
  }
  // The normalisation is in the module: without it the outputs would differ.
  if (normalize) {
    const ExampleObs x = random_example_obs(p.dims, 16, 5);
    const auto out = ll.forward({x.ego, x.goal, x.ado, x.ado_alive, x.task}).toGenericDict();
    torch::NoGradGuard no_grad;
    const auto raw = p.ll->net()(models::LlObs{x.ego, x.goal, x.ado, x.ado_alive, x.task});
    EXPECT_GT(diff(out.at("value").toTensor(), raw.value), 1e-4);
  }
}

INSTANTIATE_TEST_SUITE_P(AllHeads, ExportVariants,
                         ::testing::Values(std::make_tuple("es", true), std::make_tuple("es_d1", true),
                                           std::make_tuple("es_d2", true), std::make_tuple("es_d3", true),
                                           std::make_tuple("es_d3", false)),
                         [](const ::testing::TestParamInfo<std::tuple<std::string, bool>>& param_info) {
                           return std::get<0>(param_info.param) + (std::get<1>(param_info.param) ? "" : "_unnormalised");
                         });

// train.ll_throttle governor: the exported `action` is the greedy action with the throttle full,
// as the tournament and replay fly it (greedy_ll_actions); `mean` is still the network's.
TEST(Export, GovernorThrottleRunsExportAFullThrottle) {
  train::RunPolicy p = policy_with_stats("es_d2");
  p.config.loop.ll_throttle = train::LowLevelThrottle::kGovernor;
  torch::jit::Module ll = round_trip(make_ll_module(p), "ll_governor");
  const ExampleObs x = random_example_obs(p.dims, 23, 77);
  const auto lo = ll.forward({x.ego, x.goal, x.ado, x.ado_alive, x.task}).toGenericDict();
  const torch::Tensor mean = lo.at("mean").toTensor(), action = lo.at("action").toTensor();
  EXPECT_LT(diff(mean, ll_reference(p, x).mean), 1e-5);
  EXPECT_TRUE(action.select(1, 0).eq(1.0).all().item<bool>());
  EXPECT_TRUE(action.slice(1, 1).equal(mean.slice(1, 1).clamp(-1.0, 1.0)));
  EXPECT_FALSE(mean.select(1, 0).eq(1.0).all().item<bool>());
}

// An ensemble's high level (train.hl_tail_members, RUN+RUN): the exported module answers with the
// mean of its critics' q (and atom probabilities), each on its own normalised observations, and
// the greedy bins of that mean, for the joint, decoupled and distributional heads.
TEST(Export, EnsembleModuleIsTheMeanOfItsCritics) {
  for (const std::string agent : {"es", "es_d2", "es_d3"}) {
    train::RunPolicy p = policy_with_stats(agent);
    for (std::uint64_t seed : {8, 9}) {
      train::RunPolicy other = train::untrained_policy(tiny_config(agent), seed);
      const ExampleObs y = random_example_obs(p.dims, 64, seed, 3.0);
      other.hl->normalizer()->normalize(models::HlObs{y.ego * 3.0, y.prev_action, y.ado, y.ado_alive, y.task - 1.0}, true);
      p.hl_members.push_back(std::move(other.hl));
    }
    torch::NoGradGuard no_grad;
    const torch::jit::Module m = round_trip(make_hl_module(p), "ensemble_" + agent);
    const ExampleObs x = random_example_obs(p.dims, 96, 5);
    const models::HlObs raw{x.ego, x.prev_action, x.ado, x.ado_alive, x.task};
    const torch::Tensor q = (p.hl->q_values(raw) + p.hl_members[0]->q_values(raw) + p.hl_members[1]->q_values(raw)) / 3.0;
    const auto out = torch::jit::Module(m).forward({x.ego, x.prev_action, x.ado, x.ado_alive, x.task}).toGenericDict();
    EXPECT_LT(diff(out.at("q").toTensor(), q), 1e-4) << agent;
    EXPECT_GT(diff(p.hl->q_values(raw), q), 1e-3) << agent << ": the members should differ";
    const HlReference ref = hl_reference(p, x);
    EXPECT_LT(diff(ref.q, q), 1e-6) << agent;
    ExportReport rep;
    compare_bins(ref.q, ref.bins, out.at("bins").toTensor(), &rep);
    EXPECT_TRUE(rep.bins_equal) << agent;
    if (agent == "es_d3") {
      ASSERT_TRUE(ref.probs.defined());
      EXPECT_LT(diff(out.at("probs").toTensor(), ref.probs), 1e-4);
      EXPECT_LT(diff((ref.probs * p.hl->critic()->atoms()).sum(-1), q), 1e-4) << "q is the mixture's expectation";
    }
  }
}

TEST(Export, BadInputShapesAreRefusedByName) {
  train::RunPolicy p = policy_with_stats("es_d3");
  torch::jit::Module ll = make_ll_module(p);
  const ExampleObs x = random_example_obs(p.dims, 4, 1);
  try {
    ll.forward({x.ego, x.goal, x.ado, x.ado_alive.to(torch::kFloat32), x.task});
    FAIL() << "float ado_alive accepted";
  } catch (const std::exception& e) {
    EXPECT_NE(std::string(e.what()).find("ado_alive must be bool"), std::string::npos) << e.what();
  }
  try {
    ll.forward({x.ego, x.goal, x.ado, x.ado_alive, x.task.narrow(1, 0, 5)});
    FAIL() << "short task accepted";
  } catch (const std::exception& e) {
    EXPECT_NE(std::string(e.what()).find("task must be float32"), std::string::npos) << e.what();
  }
}

std::string trained_run(const std::string& name) {
  const fs::path dir = fs::temp_directory_path() / ("f16race_export_run_" + name);
  fs::remove_all(dir);
  train::Trainer t(tiny_config("es_d3"), dir.string());
  t.run(nullptr, 2);
  return dir.string();
}

TEST(Export, WritesTheFolderFromATrainedRun) {
  const std::string run = trained_run("ok");
  train::RunPolicy p = train::load_run_policy(run);
  const std::string out = (fs::temp_directory_path() / "f16race_export_out").string();
  fs::remove_all(out);
  const ExportReport rep = export_policy(p, out);
  EXPECT_LE(rep.hl_max_diff, kExportTol);
  EXPECT_LE(rep.ll_max_diff, kExportTol);
  EXPECT_TRUE(rep.bins_equal);
  for (const char* f : {"hl_policy.pt", "ll_policy.pt", "example_io.pt", "README.md"})
    EXPECT_TRUE(fs::exists(fs::path(out) / f)) << f;
  // The stored references are the trained networks' answers.
  torch::jit::Module io = torch::jit::load(out + "/example_io.pt");
  torch::jit::Module ll = torch::jit::load(out + "/ll_policy.pt");
  const auto mean = ll.forward({io.attr("ego"), io.attr("goal"), io.attr("ado"), io.attr("ado_alive"), io.attr("task")})
                        .toGenericDict()
                        .at("mean")
                        .toTensor();
  EXPECT_LT(diff(mean, io.attr("ll_mean").toTensor()), 1e-5);
  std::ifstream readme(out + "/README.md");
  const std::string text((std::istreambuf_iterator<char>(readme)), {});
  EXPECT_NE(text.find("| ado_alive | [B, 3] | bool |"), std::string::npos);
  EXPECT_NE(text.find("| probs | [B, 3, 7, 11] |"), std::string::npos);
}

TEST(Export, MissingOrMismatchedRunsAreRefused) {
  auto message = [](const std::string& run) {
    try {
      train::load_run_policy(run);
    } catch (const std::runtime_error& e) {
      return std::string(e.what());
    }
    return std::string("(accepted)");
  };
  EXPECT_NE(message("/nonexistent/run").find("/nonexistent/run: not a training run"), std::string::npos);
  const std::string run = trained_run("mismatch");
  // A config.yaml edited after training no longer matches the checkpoint.
  {
    std::ofstream f(run + "/config.yaml", std::ios::app);
    f << "# edited\n";
  }
  EXPECT_NE(message(run).find("hash mismatch"), std::string::npos) << message(run);
  fs::remove(fs::path(run) / "checkpoint" / "LATEST");
  EXPECT_NE(message(run).find("checkpoint/LATEST: missing"), std::string::npos) << message(run);
}

}  // namespace
// Trained networks output values up to ~10 (the LL value, C51 support +-8.5), where rounding in
// another summation order exceeds an absolute 1e-5 (every trained default run was refused that
// way): the export accepts differences within kExportTol relative to max(1, |value|).
TEST(Export, LargeOutputsPassTheRelativeCheck) {
  train::RunPolicy p = policy_with_stats("es_d2");
  {
    torch::NoGradGuard no_grad;
    for (auto& w : p.ll->net()->parameters()) w.mul_(8.0);  // values and means of tens
    for (auto& w : p.hl->critic()->parameters()) w.mul_(8.0);
  }
  const std::string out = (fs::temp_directory_path() / "f16race_export_large").string();
  fs::remove_all(out);
  const ExportReport rep = export_policy(p, out);
  EXPECT_LE(rep.hl_max_diff, kExportTol);
  EXPECT_LE(rep.ll_max_diff, kExportTol);
  const ExampleObs x = random_example_obs(p.dims, 256, 12345);
  EXPECT_GT(ll_reference(p, x).value.abs().max().item<double>(), 10.0);  // the outputs are large
  fs::remove_all(out);
}

// A differing greedy bin is a tie only when the in-process Q values both bins within
// bin_tie_tolerance (2e-4 x max(1, |Q|)).
TEST(Export, CompareBinsTellsTiesFromDisagreements) {
  auto q = torch::zeros({2, 3, 7}, torch::kFloat64);
  q[0][0][2] = 1.0;
  q[0][0][5] = 1.0 - 1e-4;  // a tie with bin 2
  q[0][1][1] = 1.0;
  q[1][2][6] = 1.0;
  q[1][2][0] = 0.5;  // not a tie
  auto ref = torch::tensor({2, 1, 0, 0, 0, 6}, torch::kInt64).view({2, 3});
  ExportReport r;
  compare_bins(q, ref, ref.clone(), &r);
  EXPECT_TRUE(r.bins_equal);
  EXPECT_EQ(r.bin_decisions, 6);
  EXPECT_EQ(r.bin_ties, 0);
  auto out = ref.clone();
  out[0][0] = 5;
  compare_bins(q, ref, out, &r);
  EXPECT_TRUE(r.bins_equal);
  EXPECT_EQ(r.bin_ties, 1);
  out[1][2] = 0;
  compare_bins(q, ref, out, &r);
  EXPECT_FALSE(r.bins_equal);
  // Joint head (es): index b0 * 49 + b1 * 7 + b2.
  auto qj = torch::zeros({1, 343}, torch::kFloat64);
  qj[0][1 * 49 + 2 * 7 + 3] = 2.0;
  qj[0][1 * 49 + 2 * 7 + 4] = 2.0;
  auto bj = torch::tensor({1, 2, 3}, torch::kInt64).view({1, 3}), oj = torch::tensor({1, 2, 4}, torch::kInt64).view({1, 3});
  compare_bins(qj, bj, oj, &r);
  EXPECT_TRUE(r.bins_equal);
  EXPECT_EQ(r.bin_decisions, 1);
  EXPECT_EQ(r.bin_ties, 1);
  compare_bins(qj, bj, torch::tensor({0, 2, 4}, torch::kInt64).view({1, 3}), &r);
  EXPECT_FALSE(r.bins_equal);
}

}  // namespace f16race::torchscript
