// f16race._core: the batched race env and the batched F-16 simulator for Python, their buffers
// handed out as NumPy arrays that view the C++ memory (no copy per step). Torch-free: it links
// the race, dynamics and io layers only. The pure-Python part of the package (python/f16race/)
// adds the Gymnasium-style spaces, the PettingZoo wrapper and load_policy on top of it.
//
// Lifetime rule (docs/python.md): every array is a view that holds the C++ object alive through
// a capsule, so a view never dangles; the env overwrites it in place at every step and reset.
#include <pybind11/numpy.h>
#include <pybind11/pybind11.h>
#include <pybind11/stl.h>

#include <omp.h>

#include <cmath>
#include <cstdint>
#include <memory>
#include <mutex>
#include <sstream>
#include <string>
#include <vector>

#include "config_versions/config_versions.hpp"
#include "dynamics/f16_batch.hpp"
#include "dynamics/trim.hpp"
#include "io/input_error.hpp"
#include "io/yaml_config.hpp"
#include "race/race_config.hpp"
#include "race/race_env.hpp"
#include "race/race_recorder.hpp"
#include "race/scripted_pilot.hpp"

namespace py = pybind11;

namespace f16race::python {
namespace {

using dynamics::F16Batch;
using race::RaceEnv;

// ---------------------------------------------------------------------------------------------
// Views

// A capsule owning one shared_ptr: the `base` of every view into `p`'s memory.
template <class T>
py::capsule owner_capsule(const std::shared_ptr<T>& p) {
  return py::capsule(new std::shared_ptr<T>(p), [](void* v) { delete static_cast<std::shared_ptr<T>*>(v); });
}

void set_read_only(py::array& a) { a.attr("setflags")(py::arg("write") = false); }

// A C-contiguous view of `data` with `shape`; dtype defaults to T's (bool views uint8 flags,
// which the env keeps at 0 or 1).
template <class T>
py::array view(const T* data, std::vector<py::ssize_t> shape, const py::capsule& base, bool writeable,
               const py::dtype& dtype = py::dtype::of<T>()) {
  py::array a(dtype, std::move(shape), static_cast<const void*>(data), base);
  if (!writeable) set_read_only(a);
  return a;
}

std::string shape_text(const py::array& a) {
  std::string s = "(";
  for (py::ssize_t k = 0; k < a.ndim(); ++k) s += (k ? ", " : "") + std::to_string(a.shape(k));
  return s + (a.ndim() == 1 ? ",)" : ")");
}

std::string shape_text(const std::vector<py::ssize_t>& shape) {
  std::string s = "(";
  for (std::size_t k = 0; k < shape.size(); ++k) s += (k ? ", " : "") + std::to_string(shape[k]);
  return s + (shape.size() == 1 ? ",)" : ")");
}

// The one check of every array the user hands in: a NumPy array of exactly this dtype and
// shape, C-contiguous (a silent conversion would copy, and could hide a float64 policy output).
// TypeError for the wrong kind of object or dtype, ValueError for the wrong shape or layout;
// each is one line naming the argument and what is expected.
py::array checked_array(const py::handle& obj, const char* what, const py::dtype& dtype, const char* dtype_name,
                        const std::vector<py::ssize_t>& shape) {
  if (!py::isinstance<py::array>(obj))
    throw py::type_error(std::string(what) + ": expected a numpy.ndarray of " + dtype_name + " with shape " +
                         shape_text(shape) + ", got " + std::string(py::str(py::type::of(obj).attr("__name__"))));
  py::array a = py::reinterpret_borrow<py::array>(obj);
  if (!a.dtype().is(dtype))
    throw py::type_error(std::string(what) + ": dtype " + std::string(py::str(a.dtype())) + ", expected " + dtype_name +
                         " (convert with .astype(np." + dtype_name + "))");
  bool same = a.ndim() == static_cast<py::ssize_t>(shape.size());
  for (std::size_t k = 0; same && k < shape.size(); ++k) same = a.shape(static_cast<py::ssize_t>(k)) == shape[k];
  if (!same)
    throw py::value_error(std::string(what) + ": shape " + shape_text(a) + ", expected " + shape_text(shape));
  if (!(a.flags() & py::array::c_style))
    throw py::value_error(std::string(what) + ": not C-contiguous; pass np.ascontiguousarray(" + what + ")");
  return a;
}

// "[e, a, k]" of flat index `flat` in a [n_env, n_agent, 3] array.
std::string index3(std::size_t flat, int n_agent, int width) {
  const std::size_t row = flat / width;
  return "[" + std::to_string(row / n_agent) + ", " + std::to_string(row % n_agent) + ", " + std::to_string(flat % width) + "]";
}

// ---------------------------------------------------------------------------------------------
// Config: the `race:` section of a YAML file (or the built-in defaults) plus overrides.

// One override as the CLI's `--set key.path=value` text. Numbers and booleans are written as
// YAML reads them back (repr keeps a float's every digit); lists become flow sequences.
std::string yaml_value(const py::handle& v, const std::string& key) {
  if (py::isinstance<py::bool_>(v)) return v.cast<bool>() ? "true" : "false";
  if (py::isinstance<py::int_>(v) || py::isinstance<py::float_>(v)) return py::repr(v);
  if (py::isinstance<py::str>(v)) return v.cast<std::string>();
  if (py::isinstance<py::list>(v) || py::isinstance<py::tuple>(v)) {
    std::string s = "[";
    bool first = true;
    for (const py::handle& x : v) {
      s += (first ? "" : ", ") + yaml_value(x, key);
      first = false;
    }
    return s + "]";
  }
  throw py::type_error("overrides['" + key + "']: a " + std::string(py::str(py::type::of(v).attr("__name__"))) +
                       "; use a number, a bool, a string or a list");
}

// RaceEnv reads the race: section only, so any other key would be silently ignored: refused.
void check_override_key(const std::string& key) {
  if (key.rfind("race.", 0) != 0)
    throw py::value_error("overrides: '" + key + "' is outside the race: section, the only one RaceEnv reads (e.g. 'race." +
                          key.substr(key.find('.') == std::string::npos ? 0 : key.find('.') + 1) + "')");
}

std::vector<std::string> override_strings(const py::object& overrides) {
  std::vector<std::string> out;
  if (overrides.is_none()) return out;
  if (py::isinstance<py::dict>(overrides)) {
    for (const auto& kv : py::reinterpret_borrow<py::dict>(overrides)) {
      if (!py::isinstance<py::str>(kv.first)) throw py::type_error("overrides: keys are 'race.key' strings");
      const std::string key = kv.first.cast<std::string>();
      check_override_key(key);
      out.push_back(key + "=" + yaml_value(kv.second, key));
    }
    return out;
  }
  if (py::isinstance<py::str>(overrides)) throw py::type_error("overrides: a dict {'race.key': value} or a list of 'race.key=value' strings");
  for (const py::handle& s : overrides) {
    if (!py::isinstance<py::str>(s)) throw py::type_error("overrides: a dict {'race.key': value} or a list of 'race.key=value' strings");
    const std::string text = s.cast<std::string>();
    check_override_key(text.substr(0, text.find('=')));
    out.push_back(text);
  }
  return out;
}

race::RaceConfig read_config(const py::object& config_path, const py::object& overrides) {
  const std::vector<std::string> sets = override_strings(overrides);
  YAML::Node root;
  std::string source;
  if (config_path.is_none()) {
    root = YAML::Node(YAML::NodeType::Map);
    source = "overrides";  // no file: the built-in defaults and these
    for (const std::string& s : sets) io::apply_override(root, s);
  } else {
    source = py::str(py::module_::import("os").attr("fspath")(config_path));
    root = io::load_yaml_with_overrides(source, sets);
  }
  config_versions::migrate(root, source, config_path.is_none() ? config_versions::Written::kByUser
                                                                : config_versions::written_by(source));
  io::ConfigReader top(root, source);
  io::ConfigReader rr = top.child("race");
  race::RaceConfig cfg;
  race::read_race_config(rr, &cfg);
  return cfg;
}

// A YAML tree as Python values (the resolved config): maps to dicts, scalars typed as YAML reads them.
py::object to_python(const YAML::Node& n) {
  if (n.IsMap()) {
    py::dict d;
    for (const auto& kv : n) d[py::str(kv.first.as<std::string>())] = to_python(kv.second);
    return std::move(d);
  }
  if (n.IsSequence()) {
    py::list l;
    for (const auto& x : n) l.append(to_python(x));
    return std::move(l);
  }
  const std::string s = n.as<std::string>();
  if (s == "true" || s == "false") return py::bool_(s == "true");
  // Whole numbers read back as int (a double key of 700.0 is written "700"); seeds up to 2**64 - 1.
  try {
    return py::int_(n.as<long long>());
  } catch (const YAML::Exception&) {
  }
  try {
    return py::int_(n.as<unsigned long long>());
  } catch (const YAML::Exception&) {
  }
  try {
    return py::float_(n.as<double>());
  } catch (const YAML::Exception&) {
    return py::str(s);
  }
}

// ---------------------------------------------------------------------------------------------
// RaceEnv

// What the views point into: the env and the ranks, which the env keeps only per aircraft
// behind accessors and this module copies into arrays after every step.
struct RaceCore {
  explicit RaceCore(const race::RaceConfig& c)
      : env(c), ego_rank(static_cast<std::size_t>(env.n_aircraft())), team_rank(ego_rank.size()) {}
  RaceEnv env;
  std::vector<std::int32_t> ego_rank;
  std::vector<double> team_rank;
  void copy_ranks() {
    for (int i = 0; i < env.n_aircraft(); ++i) {
      ego_rank[i] = env.ego_rank(i);
      team_rank[i] = env.team_rank(i);
    }
  }
};

const char* const kObsNames[] = {"ego", "prev_action", "goal", "ado", "ado_alive", "task"};

class PyRaceEnv {
 public:
  PyRaceEnv(const py::object& config_path, const py::object& overrides) {
    const race::RaceConfig cfg = read_config(config_path, overrides);
    {
      py::gil_scoped_release nogil;
      core_ = std::make_shared<RaceCore>(cfg);
      core_->copy_ranks();
    }
    seed_ = cfg.seed;
    pilot_.speed_ftps = cfg.start_speed_ftps;  // as `f16race race` flies it
    autopilot_.airspeed_ftps = cfg.start_speed_ftps;
    make_views();
  }

  const RaceEnv& env() const { return core_->env; }
  int n_env() const { return env().n_env(); }
  int n_agent() const { return env().n_agent(); }

  py::tuple reset(const py::object& seed, const py::object& options) {
    if (!options.is_none() && !(py::isinstance<py::dict>(options) && py::len(options) == 0))
      throw py::value_error("reset: options are not used by this env; configure it with overrides at construction");
    if (!seed.is_none()) {
      // Any integer (NumPy's too, through __index__), not a bool or a list of per-env seeds.
      if (!PyIndex_Check(seed.ptr()) || py::isinstance<py::bool_>(seed))
        throw py::type_error("reset: seed is one int (every env's stream is derived from it and the env's index)");
      const py::object index = py::reinterpret_steal<py::object>(PyNumber_Index(seed.ptr()));
      if (!index) throw py::error_already_set();
      std::uint64_t value = 0;
      try {
        value = index.cast<std::uint64_t>();  // refuses < 0 and >= 2**64
      } catch (const py::cast_error&) {
        throw py::value_error("reset: seed " + std::string(py::str(seed)) + " is not in [0, 2**64)");
      }
      py::gil_scoped_release nogil;
      std::lock_guard<std::mutex> lock(mu_);
      reseed(value);
    } else if (!pristine_) {
      py::gil_scoped_release nogil;
      std::lock_guard<std::mutex> lock(mu_);
      core_->env.reset();
      core_->copy_ranks();
    }
    // A reset with no seed right after construction (or a seeded reset) keeps those races, so
    // RaceEnv(race.seed = s).reset() equals the C++ RaceEnv built with seed s.
    pristine_ = false;
    return py::make_tuple(py::dict(obs_), reset_info());
  }

  py::tuple step(const py::handle& actions) {
    const py::array a = checked_array(actions, "actions", py::dtype::of<float>(), "float32", {n_env(), n_agent(), race::kActionDim});
    const float* p = static_cast<const float*>(a.data());
    const std::size_t n = static_cast<std::size_t>(env().n_aircraft()) * race::kActionDim;
    // One pass that vectorises; the slow search for where runs only on a bad batch. The env would
    // take NaN as 0 and clamp infinities: from Python a non-finite action is a bug to report.
    bool finite = true;
    for (std::size_t k = 0; k < n; ++k) finite &= std::isfinite(p[k]);
    if (!finite) {
      std::size_t k = 0;
      while (std::isfinite(p[k])) ++k;
      throw py::value_error("actions" + index3(k, n_agent(), race::kActionDim) + " is " + std::string(py::str(py::float_(p[k]))) +
                            ": actions must be finite (values outside [-1, 1] are clamped)");
    }
    race::StepStats st;
    {
      py::gil_scoped_release nogil;
      std::lock_guard<std::mutex> lock(mu_);
      st = core_->env.step(p);
      core_->copy_ranks();
    }
    pristine_ = false;
    py::dict info = step_info();
    info["stats"] = stats_dict(st);
    return py::make_tuple(py::dict(obs_), ll_reward_, terminated_, truncated_, std::move(info));
  }

  void set_hl_actions(const py::handle& bins) {
    const py::array b = checked_array(bins, "bins", py::dtype::of<std::int64_t>(), "int64", {n_env(), n_agent(), race::kHlDims});
    const auto* p = static_cast<const std::int64_t*>(b.data());
    const std::size_t n = static_cast<std::size_t>(env().n_aircraft()) * race::kHlDims;
    const std::int64_t nb = env().config().hl_bins;
    for (std::size_t k = 0; k < n; ++k)
      if (p[k] < 0 || p[k] >= nb)
        throw py::value_error("bins" + index3(k, n_agent(), race::kHlDims) + " is " + std::to_string(p[k]) + ": bins are in [0, " +
                              std::to_string(nb) + ") (race.hl_bins)");
    py::gil_scoped_release nogil;
    std::lock_guard<std::mutex> lock(mu_);
    core_->env.set_hl_actions(p);
    pristine_ = false;
  }

  // The built-in pilots' actions for every aircraft: a new array, or written into `out`.
  py::array pilot_actions(const py::object& out, bool autopilot) {
    py::array a;
    if (out.is_none()) a = py::array_t<float>(std::vector<py::ssize_t>{n_env(), n_agent(), race::kActionDim});
    else a = checked_array(out, "out", py::dtype::of<float>(), "float32", {n_env(), n_agent(), race::kActionDim});
    if (!a.writeable()) throw py::value_error("out: read-only array");
    float* p = static_cast<float*>(a.mutable_data());
    py::gil_scoped_release nogil;
    std::lock_guard<std::mutex> lock(mu_);
    if (autopilot) race::autopilot_actions(env(), autopilot_, p);
    else race::scripted_actions(env(), pilot_, p);
    return a;
  }

  py::dict observations() const { return py::dict(obs_); }
  py::dict final_observations() const { return py::dict(final_obs_); }
  py::array hl_due() const { return hl_due_; }
  py::array ego_rank() const { return ego_rank_; }
  py::array team_rank() const { return team_rank_; }
  py::array alive() const { return alive_; }
  py::array progress_ft() const { return progress_ft_; }
  py::array race_time_s() const { return race_time_s_; }
  std::uint64_t seed() const { return seed_; }

  py::dict obs_shapes() const {
    py::dict d;
    for (const char* k : kObsNames) d[k] = obs_[k].attr("shape");
    return d;
  }

  py::object config() const {
    YAML::Node node(YAML::NodeType::Map);
    io::ConfigWriter w(node);
    race::RaceConfig c = env().config();
    c.seed = seed_;
    race::write_race_config(w, c);
    return to_python(node);
  }

 private:
  // As a new RaceEnv with race.seed = seed, in place: a fresh env's exact snapshot (simulator,
  // streams, every array) loaded into this one, so every view keeps pointing at live buffers.
  // The final_* rows are left as they were: they are only meaningful where truncated is set.
  void reseed(std::uint64_t seed) {
    race::RaceConfig c = env().config();
    c.seed = seed;
    std::stringstream snapshot;
    {
      RaceEnv fresh(c);
      fresh.save_state(snapshot);
    }
    core_->env.load_state(snapshot);
    core_->copy_ranks();
    seed_ = seed;
  }

  void make_views() {
    const RaceEnv& e = env();
    const py::capsule base = owner_capsule(core_);
    const py::ssize_t ne = e.n_env(), na = e.n_agent(), no = na - 1;
    const py::dtype b = py::dtype::of<bool>();
    auto obs = [&](bool final_obs) {
      py::dict d;
      d["ego"] = view(final_obs ? e.final_ego() : e.obs_ego(), {ne, na, race::kEgoDim}, base, false);
      d["prev_action"] = view(final_obs ? e.final_prev_action() : e.obs_prev_action(), {ne, na, race::kActionDim}, base, false);
      d["goal"] = view(final_obs ? e.final_goal() : e.obs_goal(), {ne, na, race::kGoalDim}, base, false);
      d["ado"] = view(final_obs ? e.final_ado() : e.obs_ado(), {ne, na, no, e.ado_dim()}, base, false);
      d["ado_alive"] = view(final_obs ? e.final_ado_alive() : e.obs_ado_alive(), {ne, na, no}, base, false, b);
      d["task"] = view(final_obs ? e.final_task() : e.obs_task(), {ne, na, e.task_dim()}, base, false);
      return d;
    };
    obs_ = obs(false);
    final_obs_ = obs(true);
    ll_reward_ = view(e.ll_reward(), {ne, na}, base, false);
    hl_reward_ = view(e.hl_reward(), {ne, na}, base, false);
    acted_ = view(e.acted(), {ne, na}, base, false, b);
    terminated_ = view(e.terminated(), {ne, na}, base, false, b);
    truncated_ = view(e.truncated(), {ne, na}, base, false, b);
    step_cause_ = view(e.step_cause(), {ne, na}, base, false);
    hl_due_ = view(e.hl_due(), {ne}, base, false, b);
    env_done_ = view(e.env_done(), {ne}, base, false, b);
    race_winner_ = view(e.race_winner(), {ne}, base, false);
    race_end_ = view(e.race_end(), {ne}, base, false);
    ego_rank_ = view(core_->ego_rank.data(), {ne, na}, base, false);
    team_rank_ = view(core_->team_rank.data(), {ne, na}, base, false);
    alive_ = view(e.alive_data(), {ne, na}, base, false, b);
    progress_ft_ = view(e.progress_ft_data(), {ne, na}, base, false);
    race_time_s_ = view(e.race_time_s_data(), {ne}, base, false);
  }

  py::dict reset_info() const {
    py::dict d;
    d["hl_due"] = hl_due_;
    d["ego_rank"] = ego_rank_;
    d["team_rank"] = team_rank_;
    d["alive"] = alive_;
    return d;
  }

  py::dict step_info() const {
    py::dict d = reset_info();
    d["hl_reward"] = hl_reward_;
    d["acted"] = acted_;
    d["step_cause"] = step_cause_;
    d["env_done"] = env_done_;
    d["race_winner"] = race_winner_;
    d["race_end"] = race_end_;
    d["final_obs"] = py::dict(final_obs_);
    return d;
  }

  static py::dict stats_dict(const race::StepStats& s) {
    py::dict d, t;
    for (int k = 1; k < race::kNumCauses; ++k) t[race::cause_name(k)] = s.terminations[k];
    d["terminations"] = t;
    d["races_finished"] = s.races_finished;
    d["races_won_blue"] = s.races_won[0];
    d["races_won_red"] = s.races_won[1];
    d["races_drawn"] = s.races_drawn;
    d["races_by_finish_line"] = s.races_by_finish_line;
    d["races_by_elimination"] = s.races_by_elimination;
    d["races_by_time_limit"] = s.races_by_time_limit;
    d["aircraft_alive_at_end"] = s.aircraft_alive_at_end;
    return d;
  }

  std::shared_ptr<RaceCore> core_;
  std::mutex mu_;  // one C++ call at a time: the GIL is released while the env works
  bool pristine_ = true;
  std::uint64_t seed_ = 0;
  race::ScriptedPilotConfig pilot_;
  race::AutopilotPilotConfig autopilot_;
  py::dict obs_, final_obs_;
  py::array ll_reward_, hl_reward_, acted_, terminated_, truncated_, step_cause_, hl_due_, env_done_, race_winner_,
      race_end_, ego_rank_, team_rank_, alive_, progress_ft_, race_time_s_;
};

// ---------------------------------------------------------------------------------------------
// F16Batch

dynamics::AeroModel parse_model(const std::string& name) {
  dynamics::AeroModel m;
  if (!dynamics::parse_aero_model(name.c_str(), &m)) throw py::value_error("model '" + name + "': use morelli or stevens");
  return m;
}

class PyF16Batch {
 public:
  PyF16Batch(int n_env, int n_agent, const std::string& model, const std::string& integrator, const std::string& stage_law) {
    if (n_env < 1 || n_agent < 1)
      throw py::value_error("F16Batch: n_env and n_agent must be >= 1 (got " + std::to_string(n_env) + " x " +
                            std::to_string(n_agent) + ")");
    dynamics::F16BatchConfig c;
    c.n_env = n_env;
    c.n_agent = n_agent;
    c.model = parse_model(model);
    if (!dynamics::parse_integrator(integrator.c_str(), &c.integrator))
      throw py::value_error("integrator '" + integrator + "': use rk4 or euler");
    if (stage_law == "held") c.stage_law = dynamics::StageLaw::kHeld;
    else if (stage_law == "gcas") c.stage_law = dynamics::StageLaw::kGcas;
    else if (stage_law == "waypoint") c.stage_law = dynamics::StageLaw::kWaypoint;
    else throw py::value_error("stage_law '" + stage_law + "': use held, gcas or waypoint");
    sim_ = std::make_shared<F16Batch>(c);
    // Rows of `padded` doubles: a 2-D view [rows, size] strides over the padding lanes.
    const py::capsule base = owner_capsule(sim_);
    const py::ssize_t n = sim_->size(), stride = static_cast<py::ssize_t>(sim_->padded_size()) * sizeof(double);
    auto rows = [&](const double* p, int count, bool writeable) {
      py::array a(py::dtype::of<double>(), {static_cast<py::ssize_t>(count), n},
                  {stride, static_cast<py::ssize_t>(sizeof(double))}, p, base);
      if (!writeable) set_read_only(a);
      return a;
    };
    state_ = rows(sim_->state(0), dynamics::kNumStates, true);
    ref_ = rows(sim_->ref(0), dynamics::kNumRefs, true);
    output_ = rows(sim_->output(0), dynamics::kNumOutputs, false);
    if (c.stage_law != dynamics::StageLaw::kHeld) law_ = rows(sim_->law(0), dynamics::kNumLawParams, true);
    status_ = view(sim_->status(), {n}, base, false);
  }

  const F16Batch& sim() const { return *sim_; }

  int step(double dt_s, int substeps) {
    if (!(dt_s > 0.0) || !std::isfinite(dt_s)) throw py::value_error("step: dt_s must be finite and > 0, got " + std::to_string(dt_s));
    if (substeps < 1) throw py::value_error("step: substeps must be >= 1, got " + std::to_string(substeps));
    py::gil_scoped_release nogil;
    std::lock_guard<std::mutex> lock(mu_);
    return sim_->step(dt_s, substeps);
  }

  void evaluate_outputs() {
    py::gil_scoped_release nogil;
    std::lock_guard<std::mutex> lock(mu_);
    sim_->evaluate_outputs();
  }

  void reset_aircraft(int i, const py::handle& x, const py::handle& u_ref) {
    if (i < 0 || i >= sim_->size())
      throw py::index_error("reset_aircraft: aircraft " + std::to_string(i) + " is not in [0, " + std::to_string(sim_->size()) + ")");
    const auto xs = py::array_t<double, py::array::c_style | py::array::forcecast>::ensure(x);
    const auto us = py::array_t<double, py::array::c_style | py::array::forcecast>::ensure(u_ref);
    if (!xs || xs.ndim() != 1 || xs.shape(0) != dynamics::kNumStates)
      throw py::value_error("reset_aircraft: x must be 16 numbers (STATE_NAMES order)");
    if (!us || us.ndim() != 1 || us.shape(0) != dynamics::kNumRefs)
      throw py::value_error("reset_aircraft: u_ref must be 4 numbers (REF_NAMES order)");
    dynamics::StateVector sv;
    dynamics::RefVector rv;
    for (int s = 0; s < dynamics::kNumStates; ++s) sv[s] = xs.at(s);
    for (int r = 0; r < dynamics::kNumRefs; ++r) rv[r] = us.at(r);
    sim_->reset_aircraft(i, sv, rv);
  }

  py::array state() const { return state_; }
  py::array ref() const { return ref_; }
  py::array output() const { return output_; }
  py::array status() const { return status_; }
  py::array law() const {
    if (law_.is_none()) throw py::value_error("law: only with a stage law (F16Batch(..., stage_law='gcas' or 'waypoint'))");
    return law_;
  }

 private:
  std::shared_ptr<F16Batch> sim_;
  std::mutex mu_;
  py::array state_, ref_, output_, status_;
  py::object law_ = py::none();
};

const char* const kOutputNames[dynamics::kNumOutputs] = {"Nz_g",         "ps_radps",         "Ny_r_mixed",
                                                        "throttle_cmd", "elevator_cmd_deg", "aileron_cmd_deg",
                                                        "rudder_cmd_deg", "vn_ftps",        "ve_ftps",
                                                        "vu_ftps"};

template <class Names>
py::tuple names_tuple(const Names& names) {
  py::list l;
  for (const char* name : names) l.append(name);
  return py::tuple(l);
}

}  // namespace
}  // namespace f16race::python

PYBIND11_MODULE(_core, m) {
  using namespace f16race;
  using namespace f16race::python;
  m.doc() = "f16race's batched race env and F-16 simulator; arrays are views of the C++ buffers (docs/python.md)";

  // Every error a user can fix (bad config, bad key, no trim) is one ValueError line.
  py::register_exception_translator([](std::exception_ptr p) {
    try {
      if (p) std::rethrow_exception(p);
    } catch (const io::InputError& e) {
      std::string msg = e.what();
      if (msg.rfind("--set '", 0) == 0) msg = "override " + msg.substr(6);  // the CLI's name for an override
      PyErr_SetString(PyExc_ValueError, msg.c_str());
    } catch (const dynamics::TrimError& e) {
      PyErr_SetString(PyExc_ValueError, e.what());
    }
  });

  m.def("set_num_threads", [](int n) {
    if (n < 1) throw py::value_error("set_num_threads: n must be >= 1");
    omp_set_num_threads(n);
  }, py::arg("n"), "OpenMP threads for the env and simulator calls (default: all cores or OMP_NUM_THREADS)");
  m.def("get_num_threads", []() { return omp_get_max_threads(); });

  m.attr("STATE_NAMES") = names_tuple(dynamics::kStateNames);
  m.attr("REF_NAMES") = names_tuple(dynamics::kRefNames);
  m.attr("OUTPUT_NAMES") = names_tuple(kOutputNames);
  py::tuple status(9), causes(static_cast<std::size_t>(race::kNumCauses)), ends(4);
  for (int k = 0; k < 9; ++k) status[k] = py::str(dynamics::status_name(k));
  for (int k = 0; k < race::kNumCauses; ++k) causes[k] = py::str(race::cause_name(k));
  for (int k = 0; k < 4; ++k) ends[k] = py::str(race::end_reason_name(k));
  m.attr("STATUS_NAMES") = status;
  m.attr("CAUSE_NAMES") = causes;
  m.attr("END_REASONS") = ends;

  py::class_<PyRaceEnv>(m, "RaceEnv", "n_env two-team races stepped together (Gymnasium vector-env conventions)")
      .def(py::init<const py::object&, const py::object&>(), py::arg("config_path") = py::none(),
           py::arg("overrides") = py::none(),
           "config_path: a YAML config whose race: section is read (None: the built-in defaults); overrides: "
           "{'race.key.path': value} or ['race.key=value', ...]")
      .def("reset", &PyRaceEnv::reset, py::arg("seed") = py::none(), py::arg("options") = py::none(),
           "-> (obs, info). seed: as a new env with race.seed = seed; None: new races from the running streams "
           "(the first call after construction keeps the constructor's races)")
      .def("step", &PyRaceEnv::step, py::arg("actions"),
           "actions float32 [n_env, n_agent, 3] in [-1, 1] -> (obs, rewards, terminated, truncated, info); "
           "finished races restart in the same step")
      .def("set_hl_actions", &PyRaceEnv::set_hl_actions, py::arg("bins"),
           "int64 [n_env, n_agent, 3] goal bins in [0, hl_bins); used for the envs whose hl_due is set")
      .def("scripted_actions", [](PyRaceEnv& e, const py::object& out) { return e.pilot_actions(out, false); },
           py::arg("out") = py::none(), "the scripted pilot's actions for every aircraft (f16race race --policy scripted)")
      .def("autopilot_actions", [](PyRaceEnv& e, const py::object& out) { return e.pilot_actions(out, true); },
           py::arg("out") = py::none(), "AeroBench's waypoint autopilot's actions for every aircraft (--policy autopilot)")
      .def_property_readonly("observations", &PyRaceEnv::observations, "the current observations (views)")
      .def_property_readonly("final_observations", &PyRaceEnv::final_observations,
                             "observations at the time limit of races truncated this step (rows where truncated)")
      .def_property_readonly("hl_due", &PyRaceEnv::hl_due, "bool [n_env]: call set_hl_actions for these envs")
      .def_property_readonly("ego_rank", &PyRaceEnv::ego_rank, "int32 [n_env, n_agent]: aircraft strictly ahead")
      .def_property_readonly("team_rank", &PyRaceEnv::team_rank,
                             "float64 [n_env, n_agent]: the aircraft's team 0 leading, 1 trailing, 0.5 tied")
      .def_property_readonly("alive", &PyRaceEnv::alive, "bool [n_env, n_agent]")
      .def_property_readonly("progress_ft", &PyRaceEnv::progress_ft, "float64 [n_env, n_agent]: along the center-line")
      .def_property_readonly("race_time_s", &PyRaceEnv::race_time_s, "float64 [n_env]")
      .def_property_readonly("num_envs", &PyRaceEnv::n_env)
      .def_property_readonly("n_env", &PyRaceEnv::n_env)
      .def_property_readonly("n_agent", &PyRaceEnv::n_agent)
      .def_property_readonly("team_size", [](const PyRaceEnv& e) { return e.env().config().team_size; })
      .def_property_readonly("hl_bins", [](const PyRaceEnv& e) { return e.env().config().hl_bins; })
      .def_property_readonly("dt_ll_s", [](const PyRaceEnv& e) { return e.env().config().dt_ll_s; })
      .def_property_readonly("dt_hl_s", [](const PyRaceEnv& e) { return e.env().config().dt_hl_s; })
      .def_property_readonly("seed", &PyRaceEnv::seed, "the seed of the current streams")
      .def_property_readonly("obs_shapes", &PyRaceEnv::obs_shapes)
      .def_property_readonly("config", &PyRaceEnv::config, "the resolved race: section, every key");

  py::class_<PyF16Batch>(m, "F16Batch", "n_env x n_agent F-16s stepped together (RK4, OpenMP x SIMD)")
      .def(py::init<int, int, const std::string&, const std::string&, const std::string&>(), py::arg("n_env") = 1,
           py::arg("n_agent") = 1, py::arg("model") = "morelli", py::arg("integrator") = "rk4", py::arg("stage_law") = "held")
      .def("step", &PyF16Batch::step, py::arg("dt_s"), py::arg("substeps") = 1,
           "advance every ok aircraft by substeps steps of dt_s; returns how many were frozen")
      .def("evaluate_outputs", &PyF16Batch::evaluate_outputs, "fill output from the current states and references")
      .def("reset_aircraft", &PyF16Batch::reset_aircraft, py::arg("i"), py::arg("x"), py::arg("u_ref"),
           "write aircraft i's 16 states and 4 references and mark it ok")
      .def_property_readonly("state", &PyF16Batch::state, "float64 [16, size] view (STATE_NAMES), writable")
      .def_property_readonly("ref", &PyF16Batch::ref, "float64 [4, size] view (REF_NAMES), writable")
      .def_property_readonly("output", &PyF16Batch::output, "float64 [10, size] view (OUTPUT_NAMES), after evaluate_outputs")
      .def_property_readonly("status", &PyF16Batch::status, "int32 [size] view (STATUS_NAMES)")
      .def_property_readonly("law", &PyF16Batch::law, "float64 [5, size] law parameters (stage_law gcas or waypoint)")
      .def_property_readonly("size", [](const PyF16Batch& b) { return b.sim().size(); })
      .def_property_readonly("n_env", [](const PyF16Batch& b) { return b.sim().n_env(); })
      .def_property_readonly("n_agent", [](const PyF16Batch& b) { return b.sim().n_agent(); });

  m.def("trim_level_flight", [](double vt_ftps, double alt_ft, const std::string& model) {
    dynamics::TrimRequest req;
    req.model = parse_model(model);
    req.vt_ftps = vt_ftps;
    req.alt_ft = alt_ft;
    const dynamics::TrimResult t = dynamics::trim_level_flight(req);
    py::array_t<double> x(dynamics::kNumStates), u(dynamics::kNumRefs);
    for (int s = 0; s < dynamics::kNumStates; ++s) x.mutable_at(s) = t.x0[s];
    for (int r = 0; r < dynamics::kNumRefs; ++r) u.mutable_at(r) = t.u_ref[r];
    return py::make_tuple(x, u);
  }, py::arg("vt_ftps") = 540.0, py::arg("alt_ft") = 5000.0, py::arg("model") = "morelli",
  "level-flight trim -> (x0 [16], u_ref [4]); ValueError when no trim exists");
}
