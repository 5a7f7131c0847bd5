// The C++ side of tests/python/test_race_env.py: steps a RaceEnv (the executable's library, not
// the Python module's copy) with deterministic actions and writes every array after every step,
// so the Python env can be held to it byte for byte.
//
// Usage: race_env_dump CONFIG SEED STEPS OUT [race.key=value ...]
// Actions at step k (1-based): the scripted pilot for blue, ((7k + 13f) mod 21 - 10) / 20 for
// red (f the flat action index); HL bins (k + f) mod hl_bins before every step.
// OUT: records of [u32 name length][name "k/array"][u64 bytes][bytes], in the order written.
#include <cstdint>
#include <cstdio>
#include <fstream>
#include <string>
#include <vector>

#include "io/input_error.hpp"
#include "io/yaml_config.hpp"
#include "race/race_env.hpp"
#include "race/scripted_pilot.hpp"

using namespace f16race;

namespace {

class Dump {
 public:
  explicit Dump(const std::string& path) : out_(path, std::ios::binary) {}
  bool ok() const { return static_cast<bool>(out_); }
  template <class T>
  void put(int step, const std::string& name, const T* data, std::size_t count) {
    const std::string key = std::to_string(step) + "/" + name;
    const auto len = static_cast<std::uint32_t>(key.size());
    const auto bytes = static_cast<std::uint64_t>(count * sizeof(T));
    out_.write(reinterpret_cast<const char*>(&len), sizeof len);
    out_.write(key.data(), len);
    out_.write(reinterpret_cast<const char*>(&bytes), sizeof bytes);
    out_.write(reinterpret_cast<const char*>(data), static_cast<std::streamsize>(bytes));
  }

 private:
  std::ofstream out_;
};

void put_state(Dump& d, int k, const race::RaceEnv& env) {
  const std::size_t n = env.n_aircraft(), no = n * (env.n_agent() - 1), ne = env.n_env();
  d.put(k, "ego", env.obs_ego(), n * race::kEgoDim);
  d.put(k, "prev_action", env.obs_prev_action(), n * race::kActionDim);
  d.put(k, "goal", env.obs_goal(), n * race::kGoalDim);
  d.put(k, "ado", env.obs_ado(), no * env.ado_dim());
  d.put(k, "ado_alive", env.obs_ado_alive(), no);
  d.put(k, "task", env.obs_task(), n * env.task_dim());
  d.put(k, "hl_due", env.hl_due(), ne);
  d.put(k, "alive", env.alive_data(), n);
  std::vector<std::int32_t> ego(n);
  std::vector<double> team(n);
  for (std::size_t i = 0; i < n; ++i) {
    ego[i] = env.ego_rank(static_cast<int>(i));
    team[i] = env.team_rank(static_cast<int>(i));
  }
  d.put(k, "ego_rank", ego.data(), n);
  d.put(k, "team_rank", team.data(), n);
}

void put_step(Dump& d, int k, const race::RaceEnv& env, const race::StepStats& s) {
  const std::size_t n = env.n_aircraft(), ne = env.n_env(), na = env.n_agent();
  d.put(k, "ll_reward", env.ll_reward(), n);
  d.put(k, "hl_reward", env.hl_reward(), n);
  d.put(k, "acted", env.acted(), n);
  d.put(k, "terminated", env.terminated(), n);
  d.put(k, "truncated", env.truncated(), n);
  d.put(k, "step_cause", env.step_cause(), n);
  d.put(k, "env_done", env.env_done(), ne);
  d.put(k, "race_winner", env.race_winner(), ne);
  d.put(k, "race_end", env.race_end(), ne);
  std::vector<std::int32_t> stats;
  for (int c = 1; c < race::kNumCauses; ++c) stats.push_back(s.terminations[c]);
  stats.insert(stats.end(), {s.races_finished, s.races_won[0], s.races_won[1], s.races_drawn, s.races_by_finish_line,
                             s.races_by_elimination, s.races_by_time_limit, s.aircraft_alive_at_end});
  d.put(k, "stats", stats.data(), stats.size());
  // final_* rows mean something only for the envs cut by the time limit in this step.
  const std::size_t no = na - 1;
  for (std::size_t e = 0; e < ne; ++e) {
    bool cut = false;
    for (std::size_t a = 0; a < na; ++a) cut = cut || env.truncated()[e * na + a];
    if (!cut) continue;
    const std::string s_e = std::to_string(e);
    d.put(k, "final_ego/" + s_e, env.final_ego() + e * na * race::kEgoDim, na * race::kEgoDim);
    d.put(k, "final_prev_action/" + s_e, env.final_prev_action() + e * na * race::kActionDim, na * race::kActionDim);
    d.put(k, "final_goal/" + s_e, env.final_goal() + e * na * race::kGoalDim, na * race::kGoalDim);
    d.put(k, "final_ado/" + s_e, env.final_ado() + e * na * no * env.ado_dim(), na * no * env.ado_dim());
    d.put(k, "final_ado_alive/" + s_e, env.final_ado_alive() + e * na * no, na * no);
    d.put(k, "final_task/" + s_e, env.final_task() + e * na * env.task_dim(), na * env.task_dim());
  }
}

}  // namespace

int main(int argc, char** argv) {
  if (argc < 5) {
    std::fprintf(stderr, "usage: race_env_dump CONFIG SEED STEPS OUT [race.key=value ...]\n");
    return 2;
  }
  try {
    const std::vector<std::string> overrides(argv + 5, argv + argc);
    YAML::Node root = io::load_yaml_with_overrides(argv[1], overrides);
    io::ConfigReader top(root, argv[1]);
    io::ConfigReader rr = top.child("race");
    race::RaceConfig cfg;
    race::read_race_config(rr, &cfg);
    cfg.seed = std::stoull(argv[2]);
    const int steps = std::stoi(argv[3]);
    Dump dump(argv[4]);
    if (!dump.ok()) throw io::InputError(std::string(argv[4]) + ": cannot write");

    race::RaceEnv env(cfg);
    const std::size_t n = env.n_aircraft(), na = env.n_agent();
    race::ScriptedPilotConfig pilot;
    pilot.speed_ftps = cfg.start_speed_ftps;
    std::vector<float> actions(n * race::kActionDim);
    std::vector<std::int64_t> bins(n * race::kHlDims);
    put_state(dump, 0, env);
    for (int k = 1; k <= steps; ++k) {
      for (std::size_t f = 0; f < bins.size(); ++f) bins[f] = static_cast<std::int64_t>((k + f) % cfg.hl_bins);
      env.set_hl_actions(bins.data());
      race::scripted_actions(env, pilot, actions.data());
      for (std::size_t f = 0; f < actions.size(); ++f) {
        const std::size_t agent = f / race::kActionDim % na;
        if (agent >= static_cast<std::size_t>(cfg.team_size))
          actions[f] = static_cast<float>(static_cast<long long>((7 * k + 13 * f) % 21) - 10) / 20.0f;
      }
      const race::StepStats st = env.step(actions.data());
      put_step(dump, k, env, st);
      put_state(dump, k, env);
    }
    if (!dump.ok()) throw io::InputError(std::string(argv[4]) + ": write failed");
    return 0;
  } catch (const std::exception& e) {
    std::fprintf(stderr, "race_env_dump: %s\n", e.what());
    return 2;
  }
}
