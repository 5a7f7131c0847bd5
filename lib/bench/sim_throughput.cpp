#include "bench/sim_throughput.hpp"

#include <omp.h>

#include <chrono>
#include <cstdint>
#include <stdexcept>
#include <vector>

#include "bench/timing.hpp"
#include "dynamics/trim.hpp"
#include "io/input_error.hpp"
#include "race/race_env.hpp"
#include "race/scripted_pilot.hpp"

namespace f16race::bench {

using namespace f16race::dynamics;

StageLaw parse_stage_law(const std::string& text) {
  for (StageLaw l : {StageLaw::kHeld, StageLaw::kGcas, StageLaw::kWaypoint})
    if (text == stage_law_name(l)) return l;
  throw io::InputError("--law '" + text + "': use held, gcas or waypoint");
}

namespace {

// 16 trims over 450-750 ft/s and 5000-20 000 ft.
std::vector<TrimResult> spread_trims(AeroModel model) {
  constexpr int kTrims = 16;
  std::vector<TrimResult> trims;
  for (int k = 0; k < kTrims; ++k) {
    TrimRequest req;
    req.model = model;
    req.vt_ftps = 450.0 + 300.0 * k / (kTrims - 1);
    req.alt_ft = 5000.0 + 1000.0 * k;
    trims.push_back(trim_level_flight(req));
  }
  return trims;
}

}  // namespace

double sim_substeps_per_s(const SimBenchCase& c) {
  omp_set_num_threads(c.threads);
  F16BatchConfig cfg;
  cfg.n_env = c.aircraft;
  cfg.n_agent = 1;
  cfg.model = c.model;
  cfg.stage_law = c.law;
  F16Batch batch(cfg);
  const std::vector<TrimResult> trims = spread_trims(c.model);
  std::vector<double> rates;
  for (int rep = 0; rep < c.repeats + 1; ++rep) {
    for (int i = 0; i < c.aircraft; ++i) {
      const TrimResult& tr = trims[i % trims.size()];
      batch.reset_aircraft(i, tr.x0, tr.u_ref);
      // GCAS stays in standby above its deck; the waypoint law flies at a point 20 000 ft
      // north-east at the trim altitude (a turn and a speed change: every branch of the law runs).
      if (cfg.stage_law == StageLaw::kWaypoint) {
        batch.law(kLawTargetN)[i] = tr.x0[kPn] + 20000.0;
        batch.law(kLawTargetE)[i] = tr.x0[kPe] + 20000.0;
        batch.law(kLawTargetAlt)[i] = tr.x0[kAlt];
      }
    }
    const auto t0 = std::chrono::steady_clock::now();
    const int failed = batch.step(c.dt_s, c.substeps);
    const auto t1 = std::chrono::steady_clock::now();
    if (failed != 0) throw std::runtime_error("bench sim: " + std::to_string(failed) + " aircraft left the envelope");
    const double seconds = std::chrono::duration<double>(t1 - t0).count();
    if (rep > 0) rates.push_back(static_cast<double>(c.aircraft) * c.substeps / seconds);  // rep 0 warms up
  }
  return median_of(rates);
}

EnvRates env_steps_per_s(const race::RaceConfig& cfg, int threads, int steps, int repeats) {
  omp_set_num_threads(threads);
  race::RaceEnv env(cfg);
  const int n = env.n_aircraft();
  std::vector<float> actions(static_cast<std::size_t>(n) * race::kActionDim);
  std::vector<std::int64_t> bins(static_cast<std::size_t>(n) * race::kHlDims, cfg.hl_center_bin());
  std::vector<double> env_rates, sim_rates;
  F16BatchConfig bc;
  bc.n_env = cfg.n_env;
  bc.n_agent = env.n_agent();
  bc.model = cfg.model;
  F16Batch bare(bc);
  TrimRequest treq;
  treq.model = cfg.model;
  treq.vt_ftps = cfg.start_speed_ftps;
  treq.alt_ft = 10000.0;
  const TrimResult trim = trim_level_flight(treq);
  for (int rep = 0; rep < repeats + 1; ++rep) {
    double env_s = 0.0;
    for (int k = 0; k < steps; ++k) {
      env.set_hl_actions(bins.data());
      race::scripted_actions(env, race::ScriptedPilotConfig{}, actions.data());
      const auto t0 = std::chrono::steady_clock::now();
      env.step(actions.data());
      env_s += std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
    }
    for (int i = 0; i < n; ++i) bare.reset_aircraft(i, trim.x0, trim.u_ref);
    const auto t1 = std::chrono::steady_clock::now();
    for (int k = 0; k < steps; ++k) bare.step(cfg.dt_ll_s / cfg.substeps, cfg.substeps);
    const double sim_s = std::chrono::duration<double>(std::chrono::steady_clock::now() - t1).count();
    if (rep == 0) continue;  // warm-up
    env_rates.push_back(steps / env_s);
    sim_rates.push_back(steps / sim_s);
  }
  return {median_of(env_rates), median_of(sim_rates), n};
}

}  // namespace f16race::bench
