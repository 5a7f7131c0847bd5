#include "export/torchscript_export.hpp"

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <filesystem>
#include <fstream>
#include <sstream>
#include <stdexcept>
#include <string>
#include <unistd.h>
#include <vector>

#include "io/atomic_file.hpp"
#include "models/running_norm.hpp"
#include "race/race_env.hpp"

namespace f16race::torchscript {

namespace fs = std::filesystem;

namespace {

constexpr std::int64_t kCheckSamples = 256;  // random observations the export is checked on

// A double literal TorchScript reads back to the same value.
std::string num(double v) {
  char b[64];
  std::snprintf(b, sizeof b, "%.17g", v);
  std::string s = b;
  if (s.find_first_of(".eEn") == std::string::npos) s += ".0";
  return s;
}

std::string ident(const std::string& key) {
  std::string s = key;
  std::replace(s.begin(), s.end(), '.', '_');
  return s;
}

// Every parameter and buffer of `m` on `out` as "<prefix>_<key with dots as underscores>".
void copy_weights(torch::jit::Module& out, const torch::nn::Module& m, const std::string& prefix) {
  for (const auto& kv : m.named_parameters()) out.register_parameter(prefix + "_" + ident(kv.key()), kv.value().detach().clone(), false);
  for (const auto& kv : m.named_buffers()) out.register_buffer(prefix + "_" + ident(kv.key()), kv.value().detach().clone());
}

// Source compiled from C++ cannot name torch.float32 / torch.bool (no Python resolver); dtypes
// are written as their ScalarType numbers, which is how TorchScript represents them anyway.
std::string dtype_code(torch::ScalarType t) { return std::to_string(static_cast<int>(t)); }

std::string linear(const std::string& x, const std::string& layer) {
  return "torch.linear(" + x + ", self." + layer + "_weight, self." + layer + "_bias)";
}

// The normalisation terms, registered as norm_<field>_{mean,inv_std}; identity when off.
void copy_normalizer(torch::jit::Module& out, const models::ObsNormalizer& norm, bool enabled, const models::ObsDims& d) {
  const std::pair<const char*, const models::RunningNorm*> fields[] = {
      {"ego", &norm->ego()}, {"extra", &norm->extra()}, {"ado", &norm->ado()}, {"task", &norm->task()}};
  // The "extra" field is prev_action (HL) or goal (LL): both are 3 wide (race::kActionDim, kGoalDim).
  const int64_t dims[] = {d.d_ego, d.d_goal, d.d_ado, d.d_task};
  int k = 0;
  for (const auto& [name, rn] : fields) {
    const int64_t n = dims[k++];
    out.register_buffer(std::string("norm_") + name + "_mean", enabled ? (*rn)->mean_f32() : torch::zeros({n}));
    out.register_buffer(std::string("norm_") + name + "_inv_std", enabled ? (*rn)->inv_std_f32() : torch::ones({n}));
  }
}

struct Shape {
  models::ObsDims dims;
  int64_t d_model = 0, n_heads = 0;
  double clip = 10.0;
};

// Input checks, normalisation (as models::ObsNormalizer) and the attention encoder (as
// models::AttentionEncoder), op for op, so the outputs agree to float rounding.
std::string common_source(const Shape& s, const char* extra_name) {
  const auto& d = s.dims;
  const int64_t dh = s.d_model / s.n_heads;
  std::ostringstream o;
  const std::string clip = num(s.clip);
  const std::string f32 = dtype_code(torch::kFloat32), boolean = dtype_code(torch::kBool);
  o << "def check(self, ego: Tensor, " << extra_name << ": Tensor, ado: Tensor, ado_alive: Tensor, task: Tensor) -> int:\n"
    << "    assert ego.dim() == 2 and ego.size(1) == " << d.d_ego << " and ego.dtype == " << f32 << ", "
    << "\"ego must be float32 [B, " << d.d_ego << "]\"\n"
    << "    b = ego.size(0)\n"
    << "    assert list(" << extra_name << ".shape) == [b, 3] and " << extra_name << ".dtype == " << f32 << ", \""
    << extra_name << " must be float32 [B, 3]\"\n"
    << "    assert list(ado.shape) == [b, " << d.n_other << ", " << d.d_ado << "] and ado.dtype == " << f32 << ", "
    << "\"ado must be float32 [B, " << d.n_other << ", " << d.d_ado << "]\"\n"
    << "    assert list(ado_alive.shape) == [b, " << d.n_other << "] and ado_alive.dtype == " << boolean << ", "
    << "\"ado_alive must be bool [B, " << d.n_other << "]\"\n"
    << "    assert list(task.shape) == [b, " << d.d_task << "] and task.dtype == " << f32 << ", "
    << "\"task must be float32 [B, " << d.d_task << "]\"\n"
    << "    return b\n\n";
  o << "def norm(self, x: Tensor, mean: Tensor, inv_std: Tensor) -> Tensor:\n"
    << "    return torch.clamp((x - mean) * inv_std, -" << clip << ", " << clip << ")\n\n";
  const std::string enc = "net_encoder";
  o << "def encode(self, ego: Tensor, ado: Tensor, ado_alive: Tensor) -> Tensor:\n"
    << "    b = ego.size(0)\n"
    << "    q = " << linear("ego", enc + "_q_proj") << ".view([b, 1, " << s.n_heads << ", " << dh << "])\n"
    << "    k = " << linear("ado", enc + "_k_proj") << ".view([b, " << d.n_other << ", " << s.n_heads << ", " << dh << "])\n"
    << "    v = " << linear("ado", enc + "_v_proj") << ".view([b, " << d.n_other << ", " << s.n_heads << ", " << dh << "])\n"
    << "    scores = (k * q).sum(-1) / " << num(std::sqrt(static_cast<double>(dh))) << "\n"
    << "    alive = ado_alive.view([b, " << d.n_other << ", 1])\n"
    << "    scores = scores.masked_fill(alive.logical_not(), -1000000000.0)\n"
    << "    weights = torch.softmax(scores, 1) * alive.to(" << f32 << ")\n"
    << "    attended = (weights.unsqueeze(-1) * v).sum(1).reshape([b, " << s.d_model << "])\n"
    << "    any_alive = ado_alive.any(1, keepdim=True).to(" << f32 << ")\n"
    << "    return " << linear("attended", enc + "_out_proj") << " * any_alive\n\n";
  return o.str();
}

// Shared head of both forwards: checks, normalised fields, encoder, MLP input x.
std::string forward_prologue(const char* extra_name) {
  std::ostringstream o;
  o << "    b = self.check(ego, " << extra_name << ", ado, ado_alive, task)\n"
    << "    ego_n = self.norm(ego, self.norm_ego_mean, self.norm_ego_inv_std)\n"
    << "    extra_n = self.norm(" << extra_name << ", self.norm_extra_mean, self.norm_extra_inv_std)\n"
    << "    ado_n = self.norm(ado, self.norm_ado_mean, self.norm_ado_inv_std) * ado_alive.unsqueeze(-1).to(" << dtype_code(torch::kFloat32) << ")\n"
    << "    task_n = self.norm(task, self.norm_task_mean, self.norm_task_inv_std)\n";
  o << "    enc = self.encode(ego_n, ado_n, ado_alive)\n"
    << "    x = torch.cat([ego_n, extra_n, enc, task_n], 1)\n";
  return o.str();
}

// A module holding `net`'s weights and the normaliser, with the shared methods and the start of
// forward(ego, <extra>, ado, ado_alive, task) written to `o`; the caller adds the heads.
torch::jit::Module start_module(const char* class_name, const torch::nn::Module& net, const models::ObsNormalizer& norm,
                                bool normalize, const Shape& s, const char* extra_name, std::ostringstream& o) {
  torch::jit::Module m(class_name);
  copy_weights(m, net, "net");
  copy_normalizer(m, norm, normalize, s.dims);
  o << common_source(s, extra_name) << "def forward(self, ego: Tensor, " << extra_name
    << ": Tensor, ado: Tensor, ado_alive: Tensor, task: Tensor) -> Dict[str, Tensor]:\n"
    << forward_prologue(extra_name);
  return m;
}

// Serialised in memory and written by io::write_file_atomic: a full disk is one line, no
// temporary is left and an earlier export keeps its file.
void save_atomic(const torch::jit::Module& m, const std::string& path) {
  std::ostringstream bytes;
  m.save(bytes);
  io::write_file_atomic(path, bytes.str());
}

std::string bins_summary(const ExportReport& rep) {
  if (!rep.bins_equal) return "DIFFERENT";
  if (rep.bin_ties == 0) return "identical";
  return "identical except " + std::to_string(rep.bin_ties) + " of " + std::to_string(rep.bin_decisions) +
         " decisions between bins whose Q tie within " + num(2.0 * kExportTol) + " x max(1, |Q|)";
}

// max |a - b| / max(1, |b|): an absolute difference for values up to 1, a relative one above.
double max_diff(const torch::Tensor& a, const torch::Tensor& b) {
  if (!a.defined() && !b.defined()) return 0.0;
  if (!a.defined() || !b.defined() || a.sizes() != b.sizes()) return INFINITY;
  const auto bd = b.to(torch::kFloat64);
  return ((a.to(torch::kFloat64) - bd).abs() / bd.abs().clamp_min(1.0)).max().item<double>();
}

// "0 meaning; 1-2 meaning; ..." for a row of the observation spec, offsets shifted by `base`.
template <std::size_t N>
std::string field_list(const race::ObsField (&fields)[N], int base) {
  std::ostringstream o;
  for (std::size_t k = 0; k < N; ++k) {
    const race::ObsField& f = fields[k];
    o << (k > 0 ? "; " : "") << base + f.offset;
    if (f.width > 1) o << "-" << base + f.offset + f.width - 1;
    o << " " << f.meaning;
  }
  return o.str();
}

// The README's entry lists, from the one observation spec (race/observation_spec.hpp).
std::string observation_entries(const race::RaceConfig& rc) {
  std::ostringstream o;
  o << "ego: " << field_list(race::kEgoFields, 0) << ".\n\n"
    << "goal: " << field_list(race::kGoalFields, 0) << " (the goal distance is " << rc.goal_ahead() << " ft).\n\n"
    << "ado row: " << field_list(race::kAdoFields, 0) << ".\n\n"
    << "task: for p = 0.." << rc.preview_points - 1 << ", entries " << race::kPreviewWidth << "p.."
    << race::kPreviewWidth << "p+" << race::kPreviewWidth - 1 << " describe the center-line point (p+1)·"
    << rc.preview_spacing_ft << " ft ahead, entry " << race::kPreviewWidth << "p+k for k = "
    << field_list(race::kPreviewFields, 0) << "; then "
    << field_list(race::kTaskTailFields, race::kPreviewWidth * rc.preview_points) << ".\n\n";
  return o.str();
}

std::string readme(const train::RunPolicy& p, const ExportReport& rep) {
  const auto& d = p.dims;
  const auto& rc = p.config.race;
  const auto& hl = p.config.hl;
  const bool d3 = hl.variant == agents::EsVariant::kEsD3;
  const bool joint = !agents::es_is_decoupled(hl.variant);
  const int64_t nb = hl.n_bins;
  std::ostringstream o;
  o << "# Exported f16race policy: " << p.name << "\n\n"
    << "TorchScript modules of the run `" << p.run_dir << "` (checkpoint `" << fs::path(p.checkpoint_dir).filename().string()
    << "`, " << p.env_steps << " training env steps), high-level agent `" << agents::es_variant_name(hl.variant)
    << "`, trained for " << rc.team_size << " vs " << rc.team_size << " races. They need only PyTorch:\n\n"
    << "```python\nimport torch\nhl = torch.jit.load(\"hl_policy.pt\")\nll = torch.jit.load(\"ll_policy.pt\")\n"
    << "with torch.no_grad():\n    bins = hl(ego, prev_action, ado, ado_alive, task)[\"bins\"]      # every dt_hl_s = "
    << rc.dt_hl_s << " s\n    action = ll(ego, goal, ado, ado_alive, task)[\"action\"]      # every dt_ll_s = " << rc.dt_ll_s
    << " s\n```\n\n";
  if (!p.hl_members.empty())
    o << "The high level is an ensemble of " << p.hl_members.size() + 1
      << " critics trained against one low level (`train.hl_tail_members`, or runs joined by `+`): `hl_policy.pt`\n"
      << "holds each as a submodule `memberK` and answers with the greedy bins of the mean of their `q`\n"
      << (d3 ? "(and the mean of their atom probabilities, `probs`, whose expectation that is).\n\n" : "(also returned).\n\n");
  o << "B is any batch size: one row per aircraft (decentralised execution: each aircraft acts on its own\n"
    << "observation). Inputs are the raw observations the f16race environment writes (docs/race.md);\n"
    << "the running observation normalisation of training is inside the modules (clip ±" << p.config.ll.obs_clip
    << "). The two modules have their own cross-attention encoders (the HL critic and the LL actor-critic\n"
    << "were trained with separate ones), so there is no separate encoder file.\n\n"
    << "At export the modules were run on " << rep.samples << " random observations and compared with the in-process\n"
    << "networks: max difference " << rep.hl_max_diff << " (HL), " << rep.ll_max_diff
    << " (LL), each |exported - in-process| / max(1, |in-process|) (allowed " << num(kExportTol)
    << ": the same functions summed in another order), greedy bins " << bins_summary(rep) << ". `example_io.pt` holds those\n"
    << "inputs and the in-process outputs as buffers (`hl_*`, `ll_*`), to check a loader:\n\n"
    << "```python\nio = dict(torch.jit.load(\"example_io.pt\").named_buffers())\n"
    << "out = ll(io[\"ego\"], io[\"goal\"], io[\"ado\"], io[\"ado_alive\"], io[\"task\"])\n"
    << "assert ((out[\"mean\"] - io[\"ll_mean\"]).abs() / io[\"ll_mean\"].abs().clamp(min=1)).max() <= "
    << num(kExportTol) << "\n```\n\n";
  o << "## Inputs\n\n| name | shape | dtype | meaning |\n|---|---|---|---|\n"
    << "| ego | [B, " << d.d_ego << "] | float32 | own state s̄, angles as sin/cos (table below) |\n"
    << "| prev_action | [B, " << d.d_prev_action << "] | float32 | HL only: the aircraft's last LL action in [-1, 1] |\n"
    << "| goal | [B, " << d.d_goal << "] | float32 | LL only: the HL goal as a lane, ahead along the track and across it |\n"
    << "| ado | [B, " << d.n_other << ", " << d.d_ado
    << "] | float32 | one row per other aircraft, in agent order with self skipped (teammates first for blue) |\n"
    << "| ado_alive | [B, " << d.n_other << "] | bool | false = that aircraft is out (its row is ignored) |\n"
    << "| task | [B, " << d.d_task << "] | float32 | track preview and tube offsets |\n\n";
  o << observation_entries(rc);
  o << "## hl_policy.pt: forward(ego, prev_action, ado, ado_alive, task) -> Dict[str, Tensor]\n\n"
    << "| key | shape | meaning |\n|---|---|---|\n"
    << "| bins | [B, 3] int64 | greedy goal bin per axis ("
    << (rc.goal_frame == race::GoalFrame::kTrack ? "along the track, right, up" : "north, east, up") << "), each in [0, "
    << nb << ") |\n";
  if (joint)
    o << "| q | [B, " << nb * nb * nb << "] | utility of each joint action b_0·" << nb * nb << " + b_1·" << nb
      << " + b_2, b_k the bin of axis k (bins = its argmax, decoded) |\n";
  else
    o << "| q | [B, 3, " << nb << "] | utility of each bin per axis" << (d3 ? " (expected value of the atoms)" : "")
      << " |\n";
  if (d3)
    o << "| probs | [B, 3, " << nb << ", " << hl.n_atoms << "] | C51 return distribution per axis and bin over "
      << hl.n_atoms << " atoms evenly spaced in [" << hl.v_min << ", " << hl.v_max << "] |\n";
  const double half = 0.5 * (nb - 1);
  const bool track = rc.goal_frame == race::GoalFrame::kTrack;
  o << "\nThe goal point is the center-line point " << rc.goal_ahead() << " ft ahead of the aircraft, offset along "
    << (track ? "the track's\ntangent, right and up there" : "world\nnorth, east and up") << " by (b − " << half << ") · "
    << rc.goal_bin_scale << " R / " << half << " for the local tube radius R";
  if (rc.goal_line_frac > 0.0)
    o << ", plus the race's racing line there\n(the taut line through the tube within " << rc.goal_line_frac
      << " R of the center-line, race.goal_line_frac)";
  o << ", with the cross-track part clipped to " << rc.goal_bin_scale << " R (docs/race.md, \"Actions\").\n\n";
  o << "## ll_policy.pt: forward(ego, goal, ado, ado_alive, task) -> Dict[str, Tensor]\n\n"
    << "| key | shape | meaning |\n|---|---|---|\n"
    << "| mean | [B, 3] | Gaussian policy mean (the greedy action), normalised units |\n"
    << "| log_std | [B, 3] | log standard deviation (state independent) |\n"
    << "| value | [B] | critic's value estimate |\n"
    << "| action | [B, 3] | mean clipped to [-1, 1], what the environment applies |\n\n"
    << "Action to AeroBench commands: throttle = (a0 + 1)/2; Nz_ref = " << rc.nz_ref_min_g << " + (a1 + 1)/2 · "
    << rc.nz_ref_max_g - rc.nz_ref_min_g << " g; ps_ref = a2 · " << rc.ps_ref_max_radps << " rad/s; Ny_r_ref = 0.\n";
  if (p.config.loop.ll_throttle == train::LowLevelThrottle::kGovernor)
    o << "This run's throttle is the governor's (train.ll_throttle governor): `action`'s a0 is 1, full throttle,\n"
      << "which the race's Mach governor caps; `mean`'s a0 is not used.\n";
  return o.str();
}

}  // namespace

namespace {

// One high-level critic (an agent of the run) as a module: bins, q and, for es_d3, probs.
torch::jit::Module make_hl_critic_module(const train::RunPolicy& p, agents::EsAgent& agent) {
  const auto& critic = agent.critic();
  const auto& cc = critic->config();
  std::ostringstream o;
  torch::jit::Module m =
      start_module("f16race.HlPolicy", *critic, agent.normalizer(), p.config.hl.normalize_obs,
                   Shape{p.dims, cc.d_model, cc.n_heads, p.config.hl.obs_clip}, "prev_action", o);
  for (std::size_t l = 0; l < cc.hidden.size(); ++l)
    o << "    x = torch.relu(" << linear("x", "net_trunk_" + std::to_string(2 * l)) << ")\n";
  o << "    out = " << linear("x", "net_head") << "\n";
  const int64_t nb = cc.n_bins;
  if (!cc.decoupled) {
    o << "    q = out.view([b, " << nb * nb * nb << "])\n"
      << "    idx = q.argmax(1)\n"
      << "    bins = torch.stack([torch.div(idx, " << nb * nb << ", rounding_mode='floor'), "
      << "torch.remainder(torch.div(idx, " << nb << ", rounding_mode='floor'), " << nb << "), torch.remainder(idx, " << nb
      << ")], 1)\n"
      << "    return {'bins': bins, 'q': q}\n";
  } else if (cc.n_atoms == 1) {
    o << "    q = out.view([b, 3, " << nb << "])\n"
      << "    return {'bins': q.argmax(2), 'q': q}\n";
  } else {
    o << "    log_probs = torch.log_softmax(out.view([b, 3, " << nb << ", " << cc.n_atoms << "]), -1)\n"
      << "    probs = log_probs.exp()\n"
      << "    q = (probs * self.net_atoms).sum(-1)\n"
      << "    return {'bins': q.argmax(2), 'q': q, 'probs': probs}\n";
  }
  m.define(o.str());
  m.eval();
  return m;
}

}  // namespace

torch::jit::Module make_hl_module(const train::RunPolicy& p) {
  if (p.hl_members.empty()) return make_hl_critic_module(p, *p.hl);
  // An ensemble (train.hl_tail_members or RUN+RUN): each critic as a submodule, greedy on the
  // mean of their q (for es_d3 the mean of their atom probabilities, whose expectation it is).
  std::vector<agents::EsAgent*> agents{p.hl.get()};
  for (const auto& a : p.hl_members) agents.push_back(a.get());
  torch::jit::Module m("f16race.HlEnsemble");
  for (std::size_t k = 0; k < agents.size(); ++k)
    m.register_module("member" + std::to_string(k), make_hl_critic_module(p, *agents[k]));
  const auto& cc = p.hl->critic()->config();
  const bool d3 = cc.decoupled && cc.n_atoms > 1;
  const int64_t nb = cc.n_bins;
  std::ostringstream o;
  o << "def forward(self, ego: Tensor, prev_action: Tensor, ado: Tensor, ado_alive: Tensor, task: Tensor) -> "
       "Dict[str, Tensor]:\n";
  for (std::size_t k = 0; k < agents.size(); ++k) {
    o << "    o" << k << " = self.member" << k << ".forward(ego, prev_action, ado, ado_alive, task)\n";
    o << "    q" << (k == 0 ? " = " : " = q + ") << "o" << k << "['q']\n";
    if (d3) o << "    probs" << (k == 0 ? " = " : " = probs + ") << "o" << k << "['probs']\n";
  }
  const std::string n = num(static_cast<double>(agents.size()));
  o << "    q = q / " << n << "\n";
  if (d3) o << "    probs = probs / " << n << "\n";
  if (!cc.decoupled)
    o << "    idx = q.argmax(1)\n"
      << "    bins = torch.stack([torch.div(idx, " << nb * nb << ", rounding_mode='floor'), "
      << "torch.remainder(torch.div(idx, " << nb << ", rounding_mode='floor'), " << nb << "), torch.remainder(idx, " << nb
      << ")], 1)\n";
  else
    o << "    bins = q.argmax(2)\n";
  o << "    return {'bins': bins, 'q': q" << (d3 ? ", 'probs': probs" : "") << "}\n";
  m.define(o.str());
  m.eval();
  return m;
}

torch::jit::Module make_ll_module(const train::RunPolicy& p) {
  const auto& net = p.ll->net();
  const auto& nc = net->config();
  std::ostringstream o;
  torch::jit::Module m = start_module("f16race.LlPolicy", *net, p.ll->normalizer(), p.config.ll.normalize_obs,
                                      Shape{p.dims, nc.d_model, nc.n_heads, p.config.ll.obs_clip}, "goal", o);
  for (const char* part : {"actor", "critic"}) {
    o << "    h = x\n";
    for (std::size_t l = 0; l < nc.hidden.size(); ++l)
      o << "    h = torch.tanh(" << linear("h", std::string("net_") + part + "_" + std::to_string(2 * l)) << ")\n";
    o << "    " << part << "_out = " << linear("h", std::string("net_") + part + "_" + std::to_string(2 * nc.hidden.size()))
      << "\n";
  }
  o << "    mean = actor_out\n"
    << "    action = torch.clamp(mean, -1.0, 1.0)\n";
  if (p.config.loop.ll_throttle == train::LowLevelThrottle::kGovernor)  // full throttle; the governor caps it
    o << "    action = torch.cat([torch.ones_like(action[:, :1]), action[:, 1:]], 1)\n";
  o << "    return {'mean': mean, 'log_std': self.net_log_std.expand([b, " << nc.action_dim << "]), "
    << "'value': critic_out.squeeze(1), 'action': action}\n";
  m.define(o.str());
  m.eval();
  return m;
}

ExampleObs random_example_obs(const models::ObsDims& d, std::int64_t batch, std::uint64_t seed, double scale) {
  at::Generator g = models::make_generator(seed);
  ExampleObs o;
  o.ego = torch::randn({batch, d.d_ego}, g, torch::kFloat32) * scale;
  o.prev_action = torch::rand({batch, 3}, g, torch::kFloat32) * 2.0 - 1.0;
  o.goal = torch::randn({batch, 3}, g, torch::kFloat32) * scale;
  o.ado = torch::randn({batch, d.n_other, d.d_ado}, g, torch::kFloat32) * scale;
  o.ado_alive = torch::rand({batch, d.n_other}, g, torch::kFloat32) < 0.75;
  // Every eighth sample sees nobody alive: the encoder's all-dead branch.
  o.ado_alive.index_put_({torch::arange(0, batch, 8)}, false);
  o.task = torch::randn({batch, d.d_task}, g, torch::kFloat32) * scale;
  return o;
}

HlReference hl_reference(train::RunPolicy& p, const ExampleObs& x) {
  torch::NoGradGuard no_grad;
  const models::HlObs raw{x.ego, x.prev_action, x.ado, x.ado_alive, x.task};
  at::Generator g = models::make_generator(0);
  std::vector<agents::EsAgent*> agents{p.hl.get()};
  for (const auto& a : p.hl_members) agents.push_back(a.get());
  torch::Tensor q, probs;
  for (agents::EsAgent* a : agents) {
    q = q.defined() ? q + a->q_values(raw) : a->q_values(raw);
    if (p.config.hl.variant == agents::EsVariant::kEsD3) {
      const models::HlObs n = p.config.hl.normalize_obs ? a->normalizer()->normalize(raw, false) : raw;
      const torch::Tensor pr = a->critic()(n).log_probs.exp();
      probs = probs.defined() ? probs + pr : pr;
    }
  }
  const double k = static_cast<double>(agents.size());
  if (agents.size() > 1) {
    q = q / k;
    if (probs.defined()) probs = probs / k;
  }
  const agents::EsAction a = p.hl->choose(q, 0.0, g);
  return HlReference{a.greedy_bins, a.q, probs};
}

LlReference ll_reference(train::RunPolicy& p, const ExampleObs& x) {
  torch::NoGradGuard no_grad;
  const models::LlObs raw{x.ego, x.goal, x.ado, x.ado_alive, x.task};
  const models::LlOutput out = p.ll->net()(p.ll->normalize(raw, false));
  return LlReference{out.mean, out.log_std, out.value};
}

void compare_bins(const torch::Tensor& q_ref, const torch::Tensor& bins_ref, const torch::Tensor& bins_out,
                  ExportReport* report) {
  report->bins_equal = true;
  report->bin_decisions = 0;
  report->bin_ties = 0;
  if (bins_ref.sizes() != bins_out.sizes()) {
    report->bins_equal = false;
    return;
  }
  const auto q = q_ref.to(torch::kFloat64).contiguous();
  const auto br = bins_ref.to(torch::kInt64).contiguous(), bo = bins_out.to(torch::kInt64).contiguous();
  const std::int64_t b = br.size(0), axes = br.size(1);
  const std::int64_t* r = br.data_ptr<std::int64_t>();
  const std::int64_t* o = bo.data_ptr<std::int64_t>();
  const double* qp = q.data_ptr<double>();
  // A decision that differs is a tie when the reference values the exported choice within the tolerance.
  auto tally = [&](double q_ref_choice, double q_out_choice) {
    if (std::abs(q_ref_choice - q_out_choice) <= bin_tie_tolerance(q_ref_choice))
      ++report->bin_ties;
    else
      report->bins_equal = false;
  };
  if (q.dim() == 3) {  // decoupled: one decision per sample and axis
    const std::int64_t nb = q.size(2);
    report->bin_decisions = b * axes;
    for (std::int64_t i = 0; i < b * axes; ++i)
      if (r[i] != o[i]) tally(qp[i * nb + r[i]], qp[i * nb + o[i]]);
  } else {  // joint (es): one decision per sample, index b0 * nb^2 + b1 * nb + b2
    const std::int64_t n_joint = q.size(1);
    const auto nb = static_cast<std::int64_t>(std::llround(std::cbrt(static_cast<double>(n_joint))));
    report->bin_decisions = b;
    for (std::int64_t i = 0; i < b; ++i) {
      std::int64_t jr = 0, jo = 0;
      bool same = true;
      for (std::int64_t a = 0; a < axes; ++a) {
        jr = jr * nb + r[i * axes + a];
        jo = jo * nb + o[i * axes + a];
        same = same && r[i * axes + a] == o[i * axes + a];
      }
      if (!same) tally(qp[i * n_joint + jr], qp[i * n_joint + jo]);
    }
  }
}

ExportReport export_policy(train::RunPolicy& p, const std::string& out_dir) {
  torch::NoGradGuard no_grad;
  torch::jit::Module hl = make_hl_module(p), ll = make_ll_module(p);
  const ExampleObs x = random_example_obs(p.dims, kCheckSamples, 12345);
  const HlReference hr = hl_reference(p, x);
  const LlReference lr = ll_reference(p, x);
  const auto ho = hl.forward({x.ego, x.prev_action, x.ado, x.ado_alive, x.task}).toGenericDict();
  const auto lo = ll.forward({x.ego, x.goal, x.ado, x.ado_alive, x.task}).toGenericDict();
  ExportReport rep;
  rep.samples = kCheckSamples;
  compare_bins(hr.q, hr.bins, ho.at("bins").toTensor(), &rep);
  rep.hl_max_diff = max_diff(ho.at("q").toTensor(), hr.q);
  if (hr.probs.defined()) rep.hl_max_diff = std::max(rep.hl_max_diff, max_diff(ho.at("probs").toTensor(), hr.probs));
  rep.ll_max_diff = std::max({max_diff(lo.at("mean").toTensor(), lr.mean), max_diff(lo.at("log_std").toTensor(), lr.log_std),
                              max_diff(lo.at("value").toTensor(), lr.value)});
  if (!rep.bins_equal || !(rep.hl_max_diff <= kExportTol) || !(rep.ll_max_diff <= kExportTol))
    throw std::runtime_error("exported modules disagree with the trained networks (HL " + std::to_string(rep.hl_max_diff) +
                             ", LL " + std::to_string(rep.ll_max_diff) + " relative to max(1, |value|), allowed " +
                             num(kExportTol) + (rep.bins_equal ? "" : "; greedy bins differ") + "); nothing written");

  torch::jit::Module example("f16race.ExampleIO");
  for (const auto& [k, t] : std::vector<std::pair<std::string, torch::Tensor>>{
           {"ego", x.ego}, {"prev_action", x.prev_action}, {"goal", x.goal}, {"ado", x.ado}, {"ado_alive", x.ado_alive},
           {"task", x.task}, {"hl_bins", hr.bins}, {"hl_q", hr.q}, {"ll_mean", lr.mean}, {"ll_log_std", lr.log_std},
           {"ll_value", lr.value}})
    example.register_buffer(k, t.contiguous());
  if (hr.probs.defined()) example.register_buffer("hl_probs", hr.probs.contiguous());

  fs::create_directories(out_dir);
  save_atomic(hl, out_dir + "/hl_policy.pt");
  save_atomic(ll, out_dir + "/ll_policy.pt");
  save_atomic(example, out_dir + "/example_io.pt");
  io::write_file_atomic(out_dir + "/README.md", readme(p, rep));
  return rep;
}

bool is_export_output(const std::string& name) {
  return name == "hl_policy.pt" || name == "ll_policy.pt" || name == "example_io.pt" || name == "README.md";
}

}  // namespace f16race::torchscript
