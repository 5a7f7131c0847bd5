// `f16race bench train`: end-to-end training throughput (aircraft LL steps per second including
// inference and both learners' updates) with a breakdown of where the time goes, for the default
// and the paper configuration shapes.
#include <omp.h>
#include <torch/torch.h>

#include <unistd.h>

#include <CLI/CLI.hpp>
#include <filesystem>
#include <memory>
#include <string>
#include <vector>

#include "commands.hpp"
#include "io/yaml_config.hpp"
#include "train/trainer.hpp"

namespace f16race::app {
namespace {

struct TrainBenchOptions {
  // paper.yaml (1024 envs) is not a default: one of its ES updates alone collects 8 M aircraft
  // steps, tens of minutes on a 2-core machine.
  std::vector<std::string> configs{"configs/default.yaml"};
  std::vector<std::string> overrides;
  long long updates = 20;
  bool json = false;
};

void run_bench_train(const TrainBenchOptions& o) {
  torch::set_num_threads(omp_get_max_threads());
  if (!o.json)
    std::printf("f16race bench train: %lld updates per config (LL and HL phases as configured), %d threads\n",
                o.updates, omp_get_max_threads());
  for (const std::string& path : o.configs) {
    const train::TrainConfig cfg = train::read_train_config(io::load_yaml_with_overrides(path, o.overrides), path);
    // Per process, so two benches at once do not meet in one run folder.
    const std::string dir =
        (std::filesystem::temp_directory_path() / ("f16race_bench_train." + std::to_string(::getpid()))).string();
    std::filesystem::remove_all(dir);
    train::Trainer trainer(cfg, dir);
    const train::TrainSummary s = trainer.run(nullptr, o.updates);
    std::filesystem::remove_all(dir);
    const int n_agent = 2 * cfg.race.team_size;
    const double rate = static_cast<double>(s.env_steps) * n_agent / s.time.total;
    const auto& t = s.time;
    if (o.json) {
      std::printf("{\"bench\": \"train\", \"config\": \"%s\", \"envs\": %d, \"aircraft\": %d, \"threads\": %d, "
                  "\"aircraft_steps_per_s\": %.6g, \"env_s\": %.4g, \"inference_s\": %.4g, \"ppo_s\": %.4g, "
                  "\"es_s\": %.4g, \"io_s\": %.4g, \"other_s\": %.4g, \"total_s\": %.4g}\n",
                  path.c_str(), cfg.race.n_env, cfg.race.n_env * n_agent, omp_get_max_threads(), rate, t.env,
                  t.inference, t.ppo, t.es, t.io, t.other, t.total);
    } else {
      auto pct = [&](double x) { return 100.0 * x / t.total; };
      std::printf("%s: %d envs x %d aircraft, %lld env steps in %.1f s -> %.0f aircraft-steps/s end to end\n",
                  path.c_str(), cfg.race.n_env, n_agent, static_cast<long long>(s.env_steps), t.total, rate);
      std::printf("  env (sim + race + obs) %.0f%%, inference %.0f%%, PPO updates %.0f%%, ES updates %.0f%%, "
                  "I/O %.0f%%, other %.0f%%\n",
                  pct(t.env), pct(t.inference), pct(t.ppo), pct(t.es), pct(t.io), pct(t.other));
    }
    std::fflush(stdout);
  }
}

}  // namespace

void add_bench_train_command(CLI::App& bench) {
  auto o = std::make_shared<TrainBenchOptions>();
  CLI::App* cmd = bench.add_subcommand("train", "End-to-end training throughput with a time breakdown");
  cmd->add_option("--config", o->configs, "Configs to measure (default: configs/default.yaml; paper.yaml takes tens of minutes on 2 cores)");
  cmd->add_option("--updates", o->updates, "Updates per config")->check(CLI::Range(1, 100000));
  cmd->add_option("--set", o->overrides, "Override a key of every config, e.g. --set race.n_env=256 (repeatable)");
  cmd->add_flag("--json", o->json, "One JSON object per config, one per line");
  cmd->callback([o]() { run_bench_train(*o); });
}

}  // namespace f16race::app
