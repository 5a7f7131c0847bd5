#pragma once
#include <algorithm>
#include <cmath>
// TorchScript export of a trained run's greedy policies, for use without this project:
//   hl_policy.pt   forward(ego, prev_action, ado, ado_alive, task) -> Dict[str, Tensor]
//                  bins [B, 3] int64 (greedy goal bin per axis n, e, up), q (utilities), and
//                  probs (atom probabilities, es_d3 only)
//   ll_policy.pt   forward(ego, goal, ado, ado_alive, task) -> Dict[str, Tensor]
//                  mean [B, 3], log_std [B, 3], value [B], action [B, 3] (mean clipped to [-1, 1])
// Inputs are the raw observations the race env writes; the running normalisation is baked into
// the modules. The modules are built from TorchScript source with the trained weights as
// parameters (the C++ networks cannot be scripted directly), and the export checks them
// against the in-process networks before writing anything.
#include <torch/script.h>
#include <torch/torch.h>

#include <string>

#include "train/run_policy.hpp"

namespace f16race::torchscript {

torch::jit::Module make_hl_module(const train::RunPolicy& policy);
torch::jit::Module make_ll_module(const train::RunPolicy& policy);

// Random observations with the run's shapes: floats ~ N(0, scale^2), ado rows alive with
// probability 0.75 and some samples with every other aircraft dead.
struct ExampleObs {
  torch::Tensor ego, prev_action, goal, ado, ado_alive, task;
};
ExampleObs random_example_obs(const models::ObsDims& dims, std::int64_t batch, std::uint64_t seed, double scale = 2.0);

// What the in-process networks answer for `obs` (the reference the exported modules must match).
struct HlReference {
  torch::Tensor bins, q, probs;  // probs undefined unless es_d3
};
struct LlReference {
  torch::Tensor mean, log_std, value;
};
HlReference hl_reference(train::RunPolicy& policy, const ExampleObs& obs);
LlReference ll_reference(train::RunPolicy& policy, const ExampleObs& obs);

struct ExportReport {
  std::int64_t samples = 0;      // random observations compared
  // Exported vs in-process on random inputs: max |a - b| / max(1, |b|) (see kExportTol).
  double hl_max_diff = 0.0;
  double ll_max_diff = 0.0;
  bool bins_equal = true;         // no greedy decision differs, except on ties (below)
  std::int64_t bin_decisions = 0;  // greedy decisions compared (samples x axes; samples for `es`)
  std::int64_t bin_ties = 0;       // decisions that differ between two bins whose Q tie (kExportTol)
};

// Exported and in-process outputs must agree within kExportTol x max(1, |value|). They are the
// same functions computed in another order (the exported attention is composed of TorchScript
// ops, the in-process one is a fused kernel), so float rounding separates them: up to 4e-5
// absolute and 2e-5 relative on the HL Q values of trained default runs (C51 sums atoms up to
// +-8.5 into Q near 1), which an absolute 1e-5 refused.
constexpr double kExportTol = 1e-4;
// Two bins are a tie when their in-process Q differ by at most twice that: each side's value may
// be off by the tolerance, so either may be the argmax.
inline double bin_tie_tolerance(double q) { return 2.0 * kExportTol * std::max(1.0, std::abs(q)); }

// Compares exported greedy bins [B, 3] with the in-process ones, given the in-process Q
// ([B, 3, n_bins] decoupled, [B, n_bins^3] joint): sets bins_equal, bin_decisions, bin_ties.
void compare_bins(const torch::Tensor& q_ref, const torch::Tensor& bins_ref, const torch::Tensor& bins_out,
                  ExportReport* report);

// Writes hl_policy.pt, ll_policy.pt, example_io.pt (random inputs and the in-process outputs,
// for checking a loader) and README.md into out_dir; each file atomically (`f16race export`
// writes them into an io::StagedFolder, so the four appear together). Throws
// std::runtime_error if the exported modules disagree with the in-process ones (> 1e-5).
ExportReport export_policy(train::RunPolicy& policy, const std::string& out_dir);

// Whether `name` is one of the files export_policy writes (the only ones `export --out` may replace).
bool is_export_output(const std::string& name);

}  // namespace f16race::torchscript
