// `f16race bench nets`: forward and forward+backward time per aircraft sample of each network
// at a batch of 8192 aircraft (median of repeats). Inputs are random observations with the
// the default race's sizes unless overridden; 30% of the other aircraft are masked dead.
#include <torch/torch.h>

#include <CLI/CLI.hpp>
#include <algorithm>
#include <chrono>
#include <cstdio>
#include <functional>
#include <memory>
#include <string>
#include <vector>

#include "commands.hpp"
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
  int d_task = 5 * 6 + 8;
  int n_other = 7;
};

double median_of(std::vector<double> v) {
  std::sort(v.begin(), v.end());
  const std::size_t n = v.size();
  return n % 2 ? v[n / 2] : 0.5 * (v[n / 2 - 1] + v[n / 2]);
}

// Median seconds of `f` over `repeats` timed runs after one warm-up run.
double time_median_s(const std::function<void()>& f, int repeats) {
  f();
  std::vector<double> s;
  for (int r = 0; r < repeats; ++r) {
    const auto t0 = std::chrono::steady_clock::now();
    f();
    s.push_back(std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count());
  }
  return median_of(s);
}

struct NetCase {
  std::string name;
  std::function<torch::Tensor()> forward;  // returns a scalar to backpropagate
  std::vector<torch::Tensor> parameters;
};

void run_bench_nets(const NetsBenchOptions& o) {
  using namespace f16race::models;
  const ObsDims dims{o.d_ego, o.d_ado, o.d_task, o.n_other};
  const int64_t b = o.samples;
  auto gen = make_generator(1);
  torch::manual_seed(1);
  const auto normal = [&](std::vector<int64_t> s) { return torch::randn(s, gen, torch::kFloat32); };
  const auto alive = torch::rand({b, dims.n_other}, gen) < 0.7;
  const HlObs hl{normal({b, dims.d_ego}), normal({b, 3}), normal({b, dims.n_other, dims.d_ado}), alive,
                 normal({b, dims.d_task})};
  const LlObs ll{hl.ego, hl.prev_action, hl.ado, alive, hl.task};

  std::vector<NetCase> cases;
  AttentionEncoder encoder(AttentionEncoderConfig{dims.d_ego, dims.d_ado, dims.n_other, 64, 4});
  cases.push_back({"attention_encoder", [=]() mutable { return encoder(hl.ego, hl.ado, hl.ado_alive).sum(); },
                   encoder->parameters()});
  HlCriticConfig hc;
  hc.dims = dims;
  hc.decoupled = false;
  HlCritic hl_joint(hc);
  cases.push_back({"hl_critic_es", [=]() mutable { return hl_joint(hl).q.sum(); }, hl_joint->parameters()});
  hc.decoupled = true;
  HlCritic hl_decoupled(hc);
  cases.push_back({"hl_critic_es_d1_d2", [=]() mutable { return hl_decoupled(hl).q.sum(); },
                   hl_decoupled->parameters()});
  hc.n_atoms = 51;
  HlCritic hl_dist(hc);
  cases.push_back({"hl_critic_es_d3", [=]() mutable { return hl_dist(hl).log_probs.sum(); }, hl_dist->parameters()});
  LlActorCriticConfig lc;
  lc.dims = dims;
  LlActorCritic ll_net(lc);
  cases.push_back({"ll_actor_critic",
                   [=]() mutable {
                     const auto out = ll_net(ll);
                     return out.mean.sum() + out.value.sum() + out.log_std.sum();
                   },
                   ll_net->parameters()});

  if (!o.json) {
    std::printf("f16race bench nets: %d samples, median of %d runs, %d torch threads\n", o.samples, o.repeats,
                torch::get_num_threads());
    std::printf("%-20s %16s %24s\n", "network", "forward us/sample", "forward+backward us/sample");
  }
  for (auto& c : cases) {
    const double fwd_s = time_median_s(
        [&]() {
          torch::NoGradGuard no_grad;
          c.forward();
        },
        o.repeats);
    const double fwd_bwd_s = time_median_s(
        [&]() {
          for (auto& p : c.parameters) p.mutable_grad() = torch::Tensor();
          c.forward().backward();
        },
        o.repeats);
    const double fwd_us = 1e6 * fwd_s / b, fwd_bwd_us = 1e6 * fwd_bwd_s / b;
    if (o.json) {
      std::printf("{\"bench\": \"nets\", \"network\": \"%s\", \"samples\": %d, \"threads\": %d, "
                  "\"forward_us_per_sample\": %.6g, \"forward_backward_us_per_sample\": %.6g}\n",
                  c.name.c_str(), o.samples, torch::get_num_threads(), fwd_us, fwd_bwd_us);
    } else {
      std::printf("%-20s %16.4f %24.4f\n", c.name.c_str(), fwd_us, fwd_bwd_us);
    }
    std::fflush(stdout);
  }
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
