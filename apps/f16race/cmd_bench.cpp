// `f16race bench ...`: throughput measurements. Speed claims in this project come from here
// (median of several repeats, machine and thread count printed), never from unit tests.
#include <omp.h>

#include <CLI/CLI.hpp>
#include <algorithm>
#include <cstdio>
#include <string>
#include <vector>

#include "bench/fma_peak.hpp"
#include "bench/sim_throughput.hpp"
#include "dynamics/f16_batch.hpp"
#include "commands.hpp"
#include "io/input_error.hpp"
#include "io/json_text.hpp"
#include "io/numeric_mode.hpp"
#include "io/provenance.hpp"
#include "race/soak.hpp"

namespace f16race::app {
namespace {

using namespace f16race::dynamics;

struct SimBenchOptions {
  int aircraft = 8192;
  int substeps = 100;
  int repeats = 5;
  double dt_s = 0.01;
  bool json = false;
  std::vector<int> threads;
  std::string law = "held";  // held | gcas | waypoint: what sets the references at each RK stage
};

// The thread counts asked for, or 1 and all cores.
std::vector<int> measured_thread_counts(const std::vector<int>& asked) {
  std::vector<int> threads = asked;
  if (threads.empty()) {
    threads.push_back(1);
    if (omp_get_num_procs() > 1) threads.push_back(omp_get_num_procs());
  }
  return threads;
}

void run_bench_sim(const SimBenchOptions& o) {
  const std::vector<int> threads = measured_thread_counts(o.threads);
  if (!o.json) {
    std::printf("f16race bench sim: RK4 (4 closed-loop derivative evaluations per substep), dt %.3g s, references: %s\n",
                o.dt_s, o.law == "held" ? "held over each step" : (o.law + " law at every RK stage").c_str());
    std::printf("machine: %s, %d cores, %s build, %s simulator kernels; %d aircraft, %d substeps per run, median of "
                "%d runs\n", io::cpu_model().c_str(), omp_get_num_procs(), io::numeric_mode_name(),
                dynamics::wide_kernels_available() ? "AVX-512" : "the build's", o.aircraft, o.substeps, o.repeats);
  }
  // The roofline: the CPU's double FMA peak at each measured thread count (bench/fma_peak.hpp).
  std::vector<double> peak;
  for (int t : threads) {
    const bench::FmaPeak p = bench::measure_fma_peak(t, o.repeats);
    peak.push_back(p.f64_gflops);
    if (o.json)
      std::printf("{\"bench\": \"fma_peak\", \"isa\": \"%s\", \"threads\": %d, \"f32_gflops\": %.6g, "
                  "\"f64_gflops\": %.6g}\n", p.isa, t, p.f32_gflops, p.f64_gflops);
    else
      std::printf("double FMA peak at %d thread%s: %.1f GFLOP/s (%s)\n", t, t == 1 ? "" : "s", p.f64_gflops, p.isa);
  }
  if (!o.json) std::printf("%-8s %8s %10s %22s\n", "model", "threads", "aircraft", "aircraft-substeps/s");
  for (AeroModel model : {AeroModel::kMorelli, AeroModel::kStevens}) {
    for (int t : threads) {
      const double rate = bench::sim_substeps_per_s(
          {model, bench::parse_stage_law(o.law), o.aircraft, t, o.substeps, o.repeats, o.dt_s});
      if (o.json) {
        std::printf("{\"bench\": \"sim\", \"model\": %s, \"law\": %s, \"threads\": %d, \"aircraft\": %d, "
                    "\"substeps_per_s\": %.6g, \"numerics\": %s, \"wide_kernels\": %s}\n",
                    io::json_string(aero_model_name(model)).c_str(), io::json_string(o.law).c_str(), t, o.aircraft,
                    rate, io::json_string(io::numeric_mode_name()).c_str(),
                    dynamics::wide_kernels_available() ? "true" : "false");
      } else {
        std::printf("%-8s %8d %10d %22.4g\n", aero_model_name(model), t, o.aircraft, rate);
      }
      std::fflush(stdout);
    }
  }
}

struct EnvBenchOptions {
  int envs = 1024;
  int team_size = 4;
  int steps = 50;
  int repeats = 5;
  bool json = false;
  std::vector<int> threads;
};

// Env LL steps per second with observations, against the bare simulator doing the same RK4
// substeps for the same aircraft count (bench::env_steps_per_s).
void run_bench_env(const EnvBenchOptions& o) {
  const std::vector<int> threads = measured_thread_counts(o.threads);
  race::RaceConfig cfg;
  cfg.n_env = o.envs;
  cfg.team_size = o.team_size;
  if (!o.json) {
    std::printf("f16race bench env: %d envs x %d aircraft, %d RK4 substeps per LL step, %d LL steps per run, median of %d\n",
                o.envs, 2 * o.team_size, cfg.substeps, o.steps, o.repeats);
    std::printf("machine: %s, %d cores, %s build, %s simulator kernels\n", io::cpu_model().c_str(), omp_get_num_procs(),
                io::numeric_mode_name(), dynamics::wide_kernels_available() ? "AVX-512" : "the build's");
    std::printf("%8s %16s %20s %22s %10s\n", "threads", "env_steps/s", "aircraft_steps/s", "sim_only_aircraft/s", "overhead");
  }
  for (int t : threads) {
    const bench::EnvRates r = bench::env_steps_per_s(cfg, t, o.steps, o.repeats);
    const int n = r.aircraft;
    const double env_steps = r.env_steps_per_s, sim_steps = r.sim_steps_per_s;
    const double overhead = sim_steps / env_steps - 1.0;
    if (o.json) {
      std::printf("{\"bench\": \"env\", \"envs\": %d, \"aircraft\": %d, \"threads\": %d, \"env_steps_per_s\": %.6g, "
                  "\"aircraft_steps_per_s\": %.6g, \"sim_only_aircraft_steps_per_s\": %.6g}\n",
                  o.envs, n, t, env_steps, env_steps * n, sim_steps * n);
    } else {
      std::printf("%8d %16.1f %20.4g %22.4g %9.1f%%\n", t, env_steps, env_steps * n, sim_steps * n, 100.0 * overhead);
    }
    std::fflush(stdout);
  }
}

struct SoakBenchOptions {
  double aircraft_steps = 1e8;
  int envs = 256;
  int team_size = 4;
  std::uint64_t seed = 1;
  bool json = false;
};

// Hostile input through the race env (race::run_soak): the figures the README quotes.
void run_bench_soak(const SoakBenchOptions& o) {
  race::SoakOptions so;
  so.race.n_env = o.envs;
  so.race.team_size = o.team_size;
  so.race.seed = o.seed;
  so.seed = o.seed;
  so.aircraft_steps = static_cast<std::int64_t>(o.aircraft_steps);
  if (!o.json)
    std::printf("f16race bench soak: %.3g aircraft-steps of random, NaN, +-inf, +-1e30 and sign-flipping actions and "
                "out-of-range HL bins, %d envs x %d aircraft, %d threads\nmachine: %s, %s build\n",
                o.aircraft_steps, o.envs, 2 * o.team_size, omp_get_max_threads(), io::cpu_model().c_str(),
                io::numeric_mode_name());
  const race::SoakResult r = race::run_soak(so);
  if (o.json) {
    std::printf("{\"bench\": \"soak\", \"aircraft_steps\": %lld, \"non_finite\": %lld, \"races_finished\": %lld, "
                "\"hostile_action_components\": %lld, \"seconds\": %.4g, \"out\": {",
                static_cast<long long>(r.aircraft_steps), static_cast<long long>(r.non_finite),
                static_cast<long long>(r.races_finished), static_cast<long long>(r.hostile_actions), r.seconds);
    for (int c = 1; c < race::kNumCauses; ++c)
      std::printf("%s\"%s\": %lld", c > 1 ? ", " : "", race::cause_name(c), static_cast<long long>(r.out[c]));
    std::printf("}}\n");
  } else {
    std::printf("%lld aircraft-steps in %.1f s (%.3g/s), %lld hostile action components, %lld races finished\n",
                static_cast<long long>(r.aircraft_steps), r.seconds, r.aircraft_steps / r.seconds,
                static_cast<long long>(r.hostile_actions), static_cast<long long>(r.races_finished));
    std::printf("non-finite values in any observation or reward buffer: %lld\naircraft taken out, by cause:",
                static_cast<long long>(r.non_finite));
    for (int c = 1; c < race::kNumCauses; ++c)
      std::printf(" %s %lld", race::cause_name(c), static_cast<long long>(r.out[c]));
    std::printf("\n");
  }
  if (r.non_finite > 0) throw io::InputError("bench soak: non-finite values reached the env's outputs (a bug: please report it)");
}

}  // namespace

void add_bench_command(CLI::App& app, const int& threads_option) {
  CLI::App* bench = app.add_subcommand("bench", "Throughput benchmarks (medians of repeated runs)");
  bench->require_subcommand(1);
  auto sim = std::make_shared<SimBenchOptions>();
  CLI::App* cmd = bench->add_subcommand("sim", "Batched simulator: RK4 aircraft-substeps per second");
  cmd->add_option("--aircraft", sim->aircraft, "Number of aircraft")->check(CLI::Range(1, 10000000));
  cmd->add_option("--substeps", sim->substeps, "RK4 substeps per timed run")->check(CLI::Range(1, 100000));
  cmd->add_option("--repeats", sim->repeats, "Timed runs (median reported)")->check(CLI::Range(1, 1000));
  // Bounded as the global --threads is: more threads than 4 x cores only spin against each other.
  const CLI::Range thread_counts(1, 4 * std::max(1, omp_get_num_procs()));
  cmd->add_option("--threads", sim->threads, "Thread counts to measure (default: 1 and all cores)")
      ->check(thread_counts);
  cmd->add_option("--law", sim->law,
                  "What sets the references: held (default, the race env's case), or AeroBench's gcas or waypoint "
                  "autopilot evaluated at every RK stage")
      ->check(CLI::IsMember({"held", "gcas", "waypoint"}));
  cmd->add_flag("--json", sim->json, "One JSON object per measured case, one per line");
  cmd->callback([sim]() { run_bench_sim(*sim); });

  auto envo = std::make_shared<EnvBenchOptions>();
  CLI::App* ecmd = bench->add_subcommand("env", "Race env: LL steps per second with observations, vs the bare simulator");
  ecmd->add_option("--envs", envo->envs, "Parallel races")->check(CLI::Range(1, 1000000));
  ecmd->add_option("--team-size", envo->team_size, "Aircraft per team")->check(CLI::Range(1, 8));
  ecmd->add_option("--steps", envo->steps, "LL steps per timed run")->check(CLI::Range(1, 100000));
  ecmd->add_option("--repeats", envo->repeats, "Timed runs (median reported)")->check(CLI::Range(1, 1000));
  ecmd->add_option("--threads", envo->threads, "Thread counts to measure (default: 1 and all cores)")->check(thread_counts);
  ecmd->add_flag("--json", envo->json, "One JSON object per measured case, one per line");
  auto soak = std::make_shared<SoakBenchOptions>();
  CLI::App* scmd = bench->add_subcommand("soak", "Hostile actions through the race env: non-finite outputs (must be 0), "
                                                  "aircraft taken out by cause, races finished");
  scmd->add_option("--aircraft-steps", soak->aircraft_steps, "LL steps x aircraft to fly")->check(CLI::Range(1.0, 1e12));
  scmd->add_option("--envs", soak->envs, "Parallel races")->check(CLI::Range(1, 100000));
  scmd->add_option("--team-size", soak->team_size, "Aircraft per team")->check(CLI::Range(1, 8));
  scmd->add_option("--seed", soak->seed, "Seed of the tracks and of the hostile inputs")->check(kNonNegativeSeed);
  scmd->add_flag("--json", soak->json, "One JSON object");
  scmd->callback([soak]() { run_bench_soak(*soak); });
  ecmd->callback([envo]() { run_bench_env(*envo); });

  add_bench_nets_command(*bench);
  add_bench_train_command(*bench, threads_option);
}

}  // namespace f16race::app
