#include "train/train_config.hpp"

#include <yaml-cpp/yaml.h>

#include <cmath>
#include <filesystem>
#include <fstream>
#include <sstream>
#include <tuple>

#include "io/byte_hash.hpp"
#include "io/csv_table.hpp"
#include "io/input_error.hpp"
#include "config_versions/config_versions.hpp"
#include "io/yaml_config.hpp"

namespace f16race::train {
namespace {

// int64 fields through the int-based reader/writer.
template <class R>
void read_i64(R& r, const char* key, std::int64_t* v, int lo, int hi) {
  int t = static_cast<int>(*v);
  r.read(key, &t, lo, hi);
  *v = t;
}

template <class R>
void read_hidden(R& r, std::vector<std::int64_t>* v) {
  std::vector<int> t(v->begin(), v->end());
  r.read("hidden", &t, 1, 4096);
  v->assign(t.begin(), t.end());
}

template <class R>
void bind_ll(R& r, agents::PpoConfig* c) {
  read_hidden(r, &c->net.hidden);
  read_i64(r, "d_model", &c->net.d_model, 4, 1024);
  read_i64(r, "n_heads", &c->net.n_heads, 1, 64);
  r.read("init_log_std", &c->net.init_log_std, -5.0, 2.0);
  r.read("gamma", &c->gamma, 0.0, 1.0);
  r.read("gae_lambda", &c->gae_lambda, 0.0, 1.0);
  read_i64(r, "n_steps", &c->n_steps, 1, 100000);
  read_i64(r, "n_minibatches", &c->n_minibatches, 1, 100000);
  read_i64(r, "n_epochs", &c->n_epochs, 1, 1000);
  read_i64(r, "max_chunk_rows", &c->max_chunk_rows, 0, 100000000);
  r.read("clip_coef", &c->clip_coef, 0.0, 10.0);
  r.read("clip_value_loss", &c->clip_value_loss);
  r.read("vf_coef", &c->vf_coef, 0.0, 100.0);
  r.read("ent_coef", &c->ent_coef, 0.0, 10.0);
  r.read("max_grad_norm", &c->max_grad_norm, 0.0, 1e6);
  r.read("learning_rate", &c->learning_rate, 0.0, 1.0);
  r.read("anneal_lr", &c->anneal_lr);
  r.read("normalize_advantages", &c->normalize_advantages);
  r.read("normalize_obs", &c->normalize_obs);
  r.finish();
}

template <class R>
void bind_hl(R& r, agents::EsConfig* c) {
  std::string variant = agents::es_variant_name(c->variant);
  r.read("agent", &variant, {"es", "es_d1", "es_d2", "es_d3"});
  c->variant = agents::parse_es_variant(variant);
  read_hidden(r, &c->hidden);
  read_i64(r, "d_model", &c->d_model, 4, 1024);
  read_i64(r, "n_heads", &c->n_heads, 1, 64);
  read_i64(r, "n_atoms", &c->n_atoms, 2, 1001);
  r.read("v_min", &c->v_min, -1e6, 1e6);
  r.read("v_max", &c->v_max, -1e6, 1e6);
  r.read("reward_scale", &c->reward_scale, 0.0, 1e6);
  r.read("gamma", &c->gamma, 0.0, 1.0);
  r.read("epsilon", &c->epsilon, 0.0, 1.0);
  read_i64(r, "n_steps_per_update", &c->n_steps_per_update, 1, 100000);
  read_i64(r, "target_update_interval", &c->target_update_interval, 1, 1000000);
  read_i64(r, "n_epochs", &c->n_epochs, 1, 1000);
  read_i64(r, "n_minibatches", &c->n_minibatches, 1, 100000);
  read_i64(r, "minibatch_chunks", &c->minibatch_chunks, 1, 4096);
  r.read("learning_rate", &c->learning_rate, 0.0, 1.0);
  r.read("max_grad_norm", &c->max_grad_norm, 0.0, 1e6);
  r.read("huber_delta", &c->huber_delta, 1e-6, 1e6);
  r.read("component_ce_weight", &c->component_ce_weight, 0.0, 1e3);
  std::string d3_loss = c->d3_loss == agents::D3Loss::kHuberMean ? "huber_mean" : "cross_entropy";
  r.read("d3_loss", &d3_loss, {"cross_entropy", "huber_mean"});
  c->d3_loss = d3_loss == "huber_mean" ? agents::D3Loss::kHuberMean : agents::D3Loss::kCrossEntropy;
  r.finish();
}

template <class R>
void bind_loop(R& r, LoopConfig* c) {
  std::uint64_t steps = static_cast<std::uint64_t>(c->total_env_steps);
  r.read("total_env_steps", &steps);
  c->total_env_steps = static_cast<std::int64_t>(steps);
  r.read("ll_phase_updates", &c->ll_phase_updates, 1, 1000000);
  r.read("hl_phase_updates", &c->hl_phase_updates, 0, 1000000);
  r.read("checkpoint_every_updates", &c->checkpoint_every_updates, 1, 1000000);
  r.read("hl_epsilon_eval", &c->hl_epsilon_eval, 0.0, 1.0);
  r.read("log_every_updates", &c->log_every_updates, 1, 1000000);
  std::string pilot = c->ll_pilot == LowLevelPilot::kAutopilot ? "autopilot" : "ppo";
  r.read("ll_pilot", &pilot, {"ppo", "autopilot"});
  c->ll_pilot = pilot == "autopilot" ? LowLevelPilot::kAutopilot : LowLevelPilot::kPpo;
  r.read("autopilot_airspeed_ftps", &c->autopilot_airspeed_ftps, 0.0, 2000.0);
  std::string throttle = c->ll_throttle == LowLevelThrottle::kGovernor ? "governor" : "policy";
  r.read("ll_throttle", &throttle, {"policy", "governor"});
  c->ll_throttle = throttle == "governor" ? LowLevelThrottle::kGovernor : LowLevelThrottle::kPolicy;
  r.read("hl_tail_share", &c->hl_tail_share, 0.0, 0.95);
  r.skip("tail_member");  // read_tail_member's, from run folders only
  r.read("hl_tail_members", &c->hl_tail_members, 1, 16);
  r.read("ll_from", &c->ll_from, {});
  r.read("keep_hl_decisions", &c->keep_hl_decisions);
  r.finish();
}

template <class R>
void bind_pool(R& r, PoolConfig* c) {
  r.read("p_self_play", &c->p_self_play, 0.0, 1.0);
  r.read("p_center_tail", &c->p_center_tail, 0.0, 1.0);
  r.read("snapshot_every_updates", &c->snapshot_every_updates, 1, 1000000);
  r.read("max_snapshots", &c->max_snapshots, 1, 100000);
  r.read("randomize_sides", &c->randomize_sides);
  r.finish();
}

// train.total_env_steps as written (the reader took it as unsigned), for the message.
std::uint64_t steps_as_read(const YAML::Node& root) {
  try {
    return root["train"]["total_env_steps"].as<std::uint64_t>();
  } catch (const YAML::Exception&) {
    return 0;
  }
}

}  // namespace

race::AutopilotPilotConfig goal_lane_autopilot(const TrainConfig& c) {
  race::AutopilotPilotConfig pilot;
  pilot.follow_goal = true;
  pilot.airspeed_ftps = c.loop.autopilot_airspeed_ftps > 0.0 ? c.loop.autopilot_airspeed_ftps : c.race.autopilot_airspeed();
  return pilot;
}

namespace {

// train.tail_member, the tail member a run folder under RUN/members/m is (train writes it there
// when it forks them): read from run folders only. A user's config may hold it at 0 only, as the
// config.yaml of a run from before issue 51 lists it.
int read_tail_member(const YAML::Node& root, const std::string& source, ConfigOrigin origin) {
  if (!root.IsMap()) return 0;  // the reader says what is wrong with it
  const YAML::Node loop = root["train"];
  if (!loop || !loop.IsMap() || !loop["tail_member"]) return 0;
  io::ConfigReader reader(loop, source, "train");
  int m = 0;
  reader.read("tail_member", &m, 0, 1000000);
  if (m > 0 && origin == ConfigOrigin::kUser)
    throw io::ConfigError(source + ": train.tail_member = " + std::to_string(m) +
                          " is written by train into the members of a train.hl_tail_members run, not read from "
                          "a config: set train.hl_tail_members instead");
  return m;
}

// The relations between keys of different sections that no single range can check.
void check_across_sections(const TrainConfig& c, const YAML::Node& root, const std::string& source) {
  if (c.loop.total_env_steps <= 0)  // 0, or above 2^63 - 1 (read as unsigned)
    throw io::ConfigError(source + ": train.total_env_steps = " + std::to_string(steps_as_read(root)) +
                          " must be in [1, 9223372036854775807]");
  // One seed drives every stream of a run: a race.seed beside it would be ignored.
  if (root.IsMap() && root["race"] && root["race"].IsMap() && root["race"]["seed"] && c.race.seed != c.seed)
    throw io::ConfigError(source + ": race.seed = " + std::to_string(c.race.seed) + " differs from seed = " +
                          std::to_string(c.seed) + ": a training run draws its races from seed; remove race.seed");
  // Multi-head attention splits d_model into n_heads equal parts.
  for (const auto& [section, d_model, n_heads] :
       {std::tuple<const char*, std::int64_t, std::int64_t>{"ll", c.ll.net.d_model, c.ll.net.n_heads},
        {"hl", c.hl.d_model, c.hl.n_heads}})
    if (d_model % n_heads != 0)
      throw io::ConfigError(source + ": " + section + ".n_heads (" + std::to_string(n_heads) + ") must divide " + section +
                            ".d_model (" + std::to_string(d_model) + "): attention splits d_model over the heads");
  if (c.loop.ll_pilot == LowLevelPilot::kAutopilot && c.loop.hl_phase_updates == 0)
    throw io::ConfigError(source + ": train.ll_pilot is autopilot, so only the high level learns: "
                          "train.hl_phase_updates must be > 0");
  if (c.loop.ll_throttle == LowLevelThrottle::kGovernor && !c.race.mach_governor)
    throw io::ConfigError(source + ": train.ll_throttle is governor (full throttle, capped by the Mach governor) "
                          "and race.mach_governor is false: set race.mach_governor: true or train.ll_throttle: policy");
  if (!c.loop.ll_from.empty() && c.loop.ll_pilot == LowLevelPilot::kAutopilot)
    throw io::ConfigError(source + ": train.ll_from names a trained low level and train.ll_pilot is autopilot: "
                          "use one of the two");
  if (!c.loop.ll_from.empty() && c.loop.hl_phase_updates == 0)
    throw io::ConfigError(source + ": train.ll_from freezes the low level, so only the high level learns: "
                          "train.hl_phase_updates must be > 0");
  if (c.pool.p_center_tail > 0.0 && c.loop.hl_tail_share == 0.0)
    throw io::ConfigError(source + ": pool.p_center_tail = " + io::format_double(c.pool.p_center_tail) +
                          " applies to the HL-only tail, and train.hl_tail_share is 0 (no tail): set "
                          "train.hl_tail_share > 0");
  if (c.loop.tail_member > 0 && (c.loop.hl_tail_share == 0.0 || c.loop.hl_tail_members > 1))
    throw io::ConfigError(source + ": train.tail_member = " + std::to_string(c.loop.tail_member) +
                          " is a fork of a run's HL-only tail, so train.hl_tail_share must be > 0 and "
                          "train.hl_tail_members 1 (the file was edited after train wrote it?)");
  if (c.loop.hl_tail_members > 1 && c.loop.hl_tail_share == 0.0)
    throw io::ConfigError(source + ": train.hl_tail_members = " + std::to_string(c.loop.hl_tail_members) +
                          " is an ensemble of HL-only tails, and train.hl_tail_share is 0 (no tail): set "
                          "train.hl_tail_share > 0, or train.hl_tail_members to 1");
  if (c.loop.hl_tail_share > 0.0 && c.loop.hl_phase_updates == 0)
    throw io::ConfigError(source + ": train.hl_tail_share > 0 trains the high level alone at the end: "
                          "train.hl_phase_updates must be > 0");
  if (c.hl.d3_loss == agents::D3Loss::kHuberMean &&
      (c.hl.variant != agents::EsVariant::kEsD3 || c.hl.component_ce_weight > 0.0))
    throw io::ConfigError(source + ": hl.d3_loss huber_mean is ES+D3's loss on the expected value: it needs "
                          "hl.agent es_d3 and hl.component_ce_weight 0 (got " +
                          agents::es_variant_name(c.hl.variant) + ", " + io::format_double(c.hl.component_ce_weight) +
                          ")");
  if (c.ll.n_steps * c.race.n_env * c.race.team_size % c.ll.n_minibatches != 0)
    throw io::ConfigError(source + ": ll.n_minibatches (" + std::to_string(c.ll.n_minibatches) +
                          ") must divide ll.n_steps x race.n_env x race.team_size (" + std::to_string(c.ll.n_steps) +
                          " x " + std::to_string(c.race.n_env) + " x " + std::to_string(c.race.team_size) + ")");
}

}  // namespace

TrainConfig read_train_config(const YAML::Node& root, const std::string& source, ConfigOrigin origin) {
  config_versions::migrate(root, source, origin == ConfigOrigin::kRunFolder ? config_versions::Written::kByTrain
                                                                           : config_versions::Written::kByUser);
  TrainConfig c;
  c.loop.tail_member = read_tail_member(root, source, origin);
  io::ConfigReader top(root, source);
  top.read("seed", &c.seed);
  io::ConfigReader race = top.child("race");
  race::read_race_config(race, &c.race);
  io::ConfigReader ll = top.child("ll");
  bind_ll(ll, &c.ll);
  io::ConfigReader hl = top.child("hl");
  bind_hl(hl, &c.hl);
  io::ConfigReader loop = top.child("train");
  bind_loop(loop, &c.loop);
  io::ConfigReader pool = top.child("pool");
  bind_pool(pool, &c.pool);
  top.finish();
  check_across_sections(c, root, source);
  resolve_hl_scales(&c);
  if (c.hl.v_min >= c.hl.v_max)
    throw io::ConfigError(source + ": hl.v_min must be < hl.v_max (or both 0: derived from the race); got " +
                          io::format_double(c.hl.v_min) + " and " + io::format_double(c.hl.v_max));
  // One seed drives everything; the race and both learners get their own streams from it.
  c.race.seed = c.seed;
  c.ll.seed = c.seed * 2 + 11;
  c.hl.seed = c.seed * 2 + 12;
  return c;
}

namespace {
// Team term 1 plus the ego term, "an order of magnitude lower" (paper Sec. IV-A): 10 % headroom.
constexpr double kHlRewardPerStepBound = 1.1;
}  // namespace

double hl_interval_reward_bound(const TrainConfig& c) {
  const double steps_per_interval = std::ceil(c.race.dt_hl_s / c.race.dt_ll_s - 1e-9);
  return kHlRewardPerStepBound * c.hl.reward_scale * steps_per_interval;
}

double hl_return_bound(const TrainConfig& c) {
  const double decisions = std::ceil(c.race.time_limit_s / c.race.dt_hl_s - 1e-9);
  const double g = c.hl.gamma;
  const double horizon = g < 1.0 ? (1.0 - std::pow(g, decisions)) / (1.0 - g) : decisions;
  return hl_interval_reward_bound(c) * horizon;
}

void resolve_hl_scales(TrainConfig* c) {
  if (c->hl.reward_scale == 0.0) c->hl.reward_scale = c->race.dt_ll_s / c->race.dt_hl_s;
  if (c->hl.v_min == 0.0 && c->hl.v_max == 0.0) {
    // Rounded up to 3 significant digits so the resolved config.yaml reads cleanly.
    const double b = hl_return_bound(*c);
    const double p = std::pow(10.0, std::floor(std::log10(b)) - 2);
    c->hl.v_max = std::ceil(b / p) * p;
    c->hl.v_min = -c->hl.v_max;
  }
}

std::string train_config_yaml(const TrainConfig& config) {
  TrainConfig c = config;
  YAML::Node root;
  root[config_versions::kVersionKey] = config_versions::kCurrent;
  root["seed"] = c.seed;
  io::ConfigWriter race(root["race"]);
  race::write_race_config(race, c.race);
  io::ConfigWriter ll(root["ll"]);
  bind_ll(ll, &c.ll);
  io::ConfigWriter hl(root["hl"]);
  bind_hl(hl, &c.hl);
  io::ConfigWriter loop(root["train"]);
  bind_loop(loop, &c.loop);
  // Only a tail member's folder lists it (read back by read_run_config, never from a user's config).
  if (c.loop.tail_member > 0) root["train"]["tail_member"] = c.loop.tail_member;
  io::ConfigWriter pool(root["pool"]);
  bind_pool(pool, &c.pool);
  YAML::Emitter out;
  out << root;
  return std::string(out.c_str()) + "\n";
}

std::uint64_t config_hash(const std::string& text) { return io::fnv1a(text); }

RunConfig read_run_config(const std::string& run_dir) {
  const std::string path = run_dir + "/config.yaml";
  std::ifstream f(path, std::ios::binary);
  if (!std::filesystem::is_regular_file(path) || !f)
    throw io::InputError(run_dir + ": not a training run (no config.yaml); give a folder written by f16race train");
  std::stringstream text;
  text << f.rdbuf();
  RunConfig rc;
  rc.yaml = text.str();
  rc.config = read_train_config(io::parse_yaml_text(rc.yaml, path), path, ConfigOrigin::kRunFolder);
  rc.hash = config_hash(rc.yaml);
  return rc;
}

}  // namespace f16race::train
