// `f16race bench nets`: forward and forward+backward time per aircraft sample of each network
// at a batch of 8192 aircraft (median of repeats), its FLOPs per sample and the GFLOP/s reached,
// next to a large float matrix product's as the machine's practical peak. Inputs are random
// observations with the default race's sizes unless overridden; 30% of the other aircraft dead.
#include <omp.h>
#include <torch/torch.h>

#include <CLI/CLI.hpp>
#include <algorithm>
#include <cstdio>
#include <functional>
#include <memory>
#include <string>
#include <vector>

#include "bench/fma_peak.hpp"
#include "bench/network_cost.hpp"
#include "commands.hpp"
#include "io/json_text.hpp"
#include "io/numeric_mode.hpp"
#include "io/provenance.hpp"
#include "race/race_env.hpp"
#include "models/attention_encoder.hpp"
#include "models/hl_critic.hpp"
#include "models/ll_actor_critic.hpp"
#include "models/obs.hpp"

namespace f16race::app {
namespace {

struct NetsBenchOptions {
  int samples = 8192;
  int repeats = 7;
  bool json = false;
  // The race environment's sizes for the default 4 vs 4 race (6 preview points).
  int d_ego = race::kEgoDim;
  int d_ado = race::kAdoDim;
  int d_task = race::task_width(6);
  int n_other = 7;
};

struct NetCase {
  std::string name;
  std::function<torch::Tensor()> forward;  // returns a scalar to backpropagate
  std::vector<torch::Tensor> parameters;
  std::int64_t flops_per_sample;           // forward
};

// The networks of the default race, each with a forward returning a scalar to backpropagate.
std::vector<NetCase> net_cases(const models::ObsDims& dims, const models::HlObs& hl, const models::LlObs& ll) {
  using namespace f16race::models;
  std::vector<NetCase> cases;
  AttentionEncoder encoder(AttentionEncoderConfig{dims.d_ego, dims.d_ado, dims.n_other, 64, 4});
  cases.push_back({"attention_encoder", [=]() mutable { return encoder(hl.ego, hl.ado, hl.ado_alive).sum(); },
                   encoder->parameters(), encoder->flops_per_sample()});
  HlCriticConfig hc;
  hc.dims = dims;
  hc.decoupled = false;
  HlCritic hl_joint(hc);
  cases.push_back({"hl_critic_es", [=]() mutable { return hl_joint(hl).q.sum(); }, hl_joint->parameters(),
                   hl_joint->flops_per_sample()});
  hc.decoupled = true;
  HlCritic hl_decoupled(hc);
  cases.push_back({"hl_critic_es_d1_d2", [=]() mutable { return hl_decoupled(hl).q.sum(); },
                   hl_decoupled->parameters(), hl_decoupled->flops_per_sample()});
  hc.n_atoms = 51;
  HlCritic hl_dist(hc);
  cases.push_back({"hl_critic_es_d3", [=]() mutable { return hl_dist(hl).log_probs.sum(); }, hl_dist->parameters(),
                   hl_dist->flops_per_sample()});
  LlActorCriticConfig lc;
  lc.dims = dims;
  LlActorCritic ll_net(lc);
  cases.push_back({"ll_actor_critic",
                   [=]() mutable {
                     const auto out = ll_net(ll);
                     return out.mean.sum() + out.value.sum() + out.log_std.sum();
                   },
                   ll_net->parameters(), ll_net->flops_per_sample()});
  return cases;
}

// What the networks' rates are read against: this LibTorch's float matrix product (the kernels'
// practical peak) and the CPU's float FMA peak (the physical one, bench/fma_peak.hpp).
struct Reference {
  double matmul_gflops = 0.0;
  double fma_gflops = 0.0;
};

// Backward FLOPs counted as twice the forward's (per dense layer, the weight and the input
// gradients each cost the forward's multiply-adds), so a forward and backward is three forwards.
constexpr double kForwardBackwardFactor = 3.0;

// One network's forward and forward+backward medians, as a table row or a JSON line.
void time_case(NetCase& c, const NetsBenchOptions& o, const Reference& ref, const std::string& blas) {
  const double fwd_s = bench::time_median_s(
      [&]() {
        torch::NoGradGuard no_grad;
        c.forward();
      },
      o.repeats);
  const double fwd_bwd_s = bench::time_median_s(
      [&]() {
        for (auto& p : c.parameters) p.mutable_grad() = torch::Tensor();
        c.forward().backward();
      },
      o.repeats);
  const double fwd_us = 1e6 * fwd_s / o.samples, fwd_bwd_us = 1e6 * fwd_bwd_s / o.samples;
  const double gflops = static_cast<double>(c.flops_per_sample) / (fwd_us * 1e3);
  const double fb_gflops = kForwardBackwardFactor * static_cast<double>(c.flops_per_sample) / (fwd_bwd_us * 1e3);
  if (o.json) {
    std::printf("{\"bench\": \"nets\", \"network\": %s, \"samples\": %d, \"threads\": %d, "
                "\"flops_per_sample\": %lld, \"backward_flops_per_sample\": %lld, \"forward_us_per_sample\": %.6g, "
                "\"forward_backward_us_per_sample\": %.6g, \"forward_gflops\": %.6g, "
                "\"forward_backward_gflops\": %.6g, \"matmul_gflops\": %.6g, \"fma_peak_gflops\": %.6g, "
                "\"forward_fma_share\": %.4g, \"forward_backward_fma_share\": %.4g, \"blas_core\": %s, "
                "\"numerics\": %s}\n",
                io::json_string(c.name).c_str(), o.samples, torch::get_num_threads(),
                static_cast<long long>(c.flops_per_sample), static_cast<long long>(2 * c.flops_per_sample), fwd_us,
                fwd_bwd_us, gflops, fb_gflops, ref.matmul_gflops, ref.fma_gflops, gflops / ref.fma_gflops,
                fb_gflops / ref.fma_gflops, io::json_string(blas).c_str(),
                io::json_string(io::numeric_mode_name()).c_str());
  } else {
    std::printf("%-20s %12.1f %12.4f %10.1f %12.4f %10.2f %9.3f %9.3f\n", c.name.c_str(), 1e-3 * c.flops_per_sample,
                fwd_us, gflops, fwd_bwd_us, gflops / ref.matmul_gflops, gflops / ref.fma_gflops,
                fb_gflops / ref.fma_gflops);
  }
  std::fflush(stdout);
}

// The forwards on the Eigen kernels (PpoConfig and EsConfig::eigen_inference, rollouts only):
// forward alone. The HL one for the shared es_d1/es_d2 critic.
void time_eigen_forwards(const NetsBenchOptions& o, const models::ObsDims& dims, const Reference& ref) {
  models::LlActorCriticConfig lc;
  lc.dims = dims;
  models::HlCriticConfig hc;
  hc.dims = dims;
  hc.decoupled = true;
  const struct {
    const char* name;
    const char* short_name;
    std::int64_t flops;
    double us;
  } eigen_cases[] = {
      {"ll_actor_critic_eigen", "ll_actor_critic_eig", models::LlActorCritic(lc)->flops_per_sample(),
       1e6 * bench::measure_ll_cost(lc, o.samples, o.repeats, /*eigen_forward=*/true).forward_s},
      {"hl_critic_es_d1_d2_eigen", "hl_critic_d1_d2_eig", models::HlCritic(hc)->flops_per_sample(),
       1e6 * bench::measure_hl_cost(hc, o.samples, o.repeats, 1, /*eigen_forward=*/true).forward_s},
  };
  for (const auto& e : eigen_cases) {
    const double eigen_gflops = static_cast<double>(e.flops) / (e.us * 1e3);
    if (o.json)
      std::printf("{\"bench\": \"nets\", \"network\": \"%s\", \"samples\": %d, \"threads\": %d, "
                  "\"flops_per_sample\": %lld, \"forward_us_per_sample\": %.6g, \"forward_gflops\": %.6g, "
                  "\"matmul_gflops\": %.6g, \"fma_peak_gflops\": %.6g, \"forward_fma_share\": %.4g}\n",
                  e.name, o.samples, torch::get_num_threads(), static_cast<long long>(e.flops), e.us, eigen_gflops,
                  ref.matmul_gflops, ref.fma_gflops, eigen_gflops / ref.fma_gflops);
    else
      std::printf("%-20s %12.1f %12.4f %10.1f %12s %10.2f %9.3f %9s\n", e.short_name, 1e-3 * e.flops, e.us, eigen_gflops,
                  "-", eigen_gflops / ref.matmul_gflops, eigen_gflops / ref.fma_gflops, "-");
  }
}

// The forward+backward as training runs it (PpoConfig and EsConfig::fused_training: the fused
// pass, models/kernels/attention_mlp_train.hpp) for the LL and the HL critics ES+D2 and ES+D3
// (the head's logits; ES+D3's log-softmax is the loss's), one pass per thread side by side as
// their chunks run.
void time_fused_training(const NetsBenchOptions& o, const models::ObsDims& dims, const Reference& ref) {
  const int threads = torch::get_num_threads();
  models::LlActorCriticConfig lc;
  lc.dims = dims;
  models::HlCriticConfig d2;
  d2.dims = dims;
  d2.decoupled = true;
  models::HlCriticConfig d3 = d2;
  d3.n_atoms = 51;
  const auto hl_us = [&](const models::HlCriticConfig& c) {
    return 1e6 * bench::measure_hl_cost(c, o.samples, o.repeats, threads, false, bench::kDefaultAliveShare,
                                        /*fused_train=*/true)
                     .forward_backward_s;
  };
  const struct {
    const char* name;
    const char* short_name;
    std::int64_t flops;
    double us;
  } fused_cases[] = {
      {"ll_actor_critic_fused", "ll_actor_critic_fus", models::LlActorCritic(lc)->flops_per_sample(),
       1e6 * bench::measure_ll_cost(lc, o.samples, o.repeats, false, threads, bench::kDefaultAliveShare,
                                    /*fused_train=*/true)
                 .forward_backward_s},
      {"hl_critic_es_d1_d2_fused", "hl_critic_d1_d2_fus", models::HlCritic(d2)->flops_per_sample(), hl_us(d2)},
      {"hl_critic_es_d3_fused", "hl_critic_d3_fus", models::HlCritic(d3)->flops_per_sample(), hl_us(d3)},
  };
  for (const auto& e : fused_cases) {
    const double gflops = kForwardBackwardFactor * static_cast<double>(e.flops) / (e.us * 1e3);
    if (o.json)
      std::printf("{\"bench\": \"nets\", \"network\": \"%s\", \"samples\": %d, \"threads\": %d, "
                  "\"flops_per_sample\": %lld, \"backward_flops_per_sample\": %lld, "
                  "\"forward_backward_us_per_sample\": %.6g, \"forward_backward_gflops\": %.6g, "
                  "\"fma_peak_gflops\": %.6g, \"forward_backward_fma_share\": %.4g}\n",
                  e.name, o.samples, threads, static_cast<long long>(e.flops), static_cast<long long>(2 * e.flops),
                  e.us, gflops, ref.fma_gflops, gflops / ref.fma_gflops);
    else
      std::printf("%-20s %12.1f %12s %10s %12.4f %10s %9s %9.3f\n", e.short_name, 1e-3 * e.flops, "-", "-", e.us,
                  "-", "-", gflops / ref.fma_gflops);
  }
}

// The networks' own product, both copies where the CPU runs both (the same bits), against one
// core's share of the FMA peak.
void report_fixed_order_gemm(const NetsBenchOptions& o, const bench::FmaPeak& fma) {
  using models::kernels::GemmIsa;
  const double core_peak = fma.f32_gflops / std::max(1, fma.threads);
  std::vector<GemmIsa> isas{GemmIsa::kAvx2};
  if (models::kernels::avx512_gemm_available()) isas.push_back(GemmIsa::kAvx512);
  for (GemmIsa isa : isas) {
    const double gflops = bench::fixed_order_gemm_gflops(isa, o.repeats);
    const char* name = models::kernels::gemm_isa_name(isa);
    const bool used = isa == models::kernels::gemm_isa_in_use();
    if (o.json)
      std::printf("{\"bench\": \"fixed_order_gemm\", \"isa\": \"%s\", \"in_use\": %s, \"m\": 459, \"k\": 101, "
                  "\"n\": 64, \"gflops\": %.6g, \"core_fma_peak_gflops\": %.6g, \"fma_share\": %.4g}\n",
                  name, used ? "true" : "false", gflops, core_peak, gflops / core_peak);
    else
      std::printf("fixed-order product [459 x 101] x [101 x 64], one thread, %s copy%s: %.1f GFLOP/s, %.2f of a core's "
                  "FMA peak\n",
                  name, used ? " (in use)" : "", gflops, gflops / core_peak);
  }
}

void run_bench_nets(const NetsBenchOptions& o) {
  torch::set_num_threads(omp_get_max_threads());
  const models::ObsDims dims{o.d_ego, o.d_ado, o.d_task, o.n_other};
  auto gen = models::make_generator(1);
  torch::manual_seed(1);
  const models::HlObs hl = bench::random_hl_obs(dims, o.samples, gen);
  const models::LlObs ll{hl.ego, hl.prev_action, hl.ado, hl.ado_alive, hl.task};
  std::vector<NetCase> cases = net_cases(dims, hl, ll);

  // The references: what this LibTorch's float matrix product reaches here at these threads, and
  // what the CPU's FMA units can.
  Reference ref;
  ref.matmul_gflops = bench::matmul_gflops(o.repeats);
  const bench::FmaPeak fma = bench::measure_fma_peak(torch::get_num_threads(), o.repeats);
  ref.fma_gflops = fma.f32_gflops;
  const std::string blas = io::blas_core();
  if (o.json) {
    std::printf("{\"bench\": \"fma_peak\", \"isa\": \"%s\", \"threads\": %d, \"f32_gflops\": %.6g, "
                "\"f64_gflops\": %.6g}\n",
                fma.isa, fma.threads, fma.f32_gflops, fma.f64_gflops);
  } else {
    std::printf("f16race bench nets: %d samples, median of %d runs, %d torch threads, %s build\n", o.samples, o.repeats,
                torch::get_num_threads(), io::numeric_mode_name());
    std::printf("reference: 1024^3 float matrix product %.1f GFLOP/s (%s); float FMA peak %.1f GFLOP/s (%s, %d "
                "threads; double %.1f)\n",
                ref.matmul_gflops, blas.empty() ? "BLAS: not OpenBLAS" : ("OpenBLAS kernels: " + blas).c_str(),
                fma.f32_gflops, fma.isa, fma.threads, fma.f64_gflops);
  }
  report_fixed_order_gemm(o, fma);
  if (!o.json) {
    std::printf("x matmul, x FMA: the forward's GF/s as a share of the matrix product's and of the FMA peak; f+b: the\n"
                "forward and backward's, counting the backward as twice the forward's FLOPs\n");
    std::printf("%-20s %12s %12s %10s %12s %10s %9s %9s\n", "network", "kFLOP/sample", "fwd us/smp", "fwd GF/s",
                "fwd+bwd us", "x matmul", "x FMA", "f+b xFMA");
  }
  for (auto& c : cases) time_case(c, o, ref, blas);
  time_eigen_forwards(o, dims, ref);
  time_fused_training(o, dims, ref);
}

}  // namespace

void add_bench_nets_command(CLI::App& bench) {
  auto o = std::make_shared<NetsBenchOptions>();
  CLI::App* cmd = bench.add_subcommand("nets", "Networks: forward and forward+backward time per aircraft sample");
  cmd->add_option("--samples", o->samples, "Aircraft samples per batch")->check(CLI::Range(1, 10000000));
  cmd->add_option("--repeats", o->repeats, "Timed runs (median reported)")->check(CLI::Range(1, 1000));
  cmd->add_option("--d-ego", o->d_ego, "Ego feature size")->check(CLI::Range(1, 100000));
  cmd->add_option("--d-ado", o->d_ado, "Feature size of one other aircraft")->check(CLI::Range(1, 100000));
  cmd->add_option("--d-task", o->d_task, "Task feature size")->check(CLI::Range(1, 100000));
  cmd->add_option("--n-other", o->n_other, "Other aircraft per sample")->check(CLI::Range(1, 100000));
  cmd->add_flag("--json", o->json, "One JSON object per network, one per line");
  cmd->callback([o]() { run_bench_nets(*o); });
}

}  // namespace f16race::app
