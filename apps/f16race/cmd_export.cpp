// `f16race export`: a trained run's policies as TorchScript modules plain PyTorch can load.
#include <CLI/CLI.hpp>
#include <cstdio>
#include <memory>
#include <string>

#include "commands.hpp"
#include "export/torchscript_export.hpp"
#include "io/input_error.hpp"
#include "io/staged_folder.hpp"
#include "train/policy_copy.hpp"
#include "train/run_policy.hpp"

namespace f16race::app {
namespace {

struct ExportOptions {
  std::string run;
  std::string out;
  std::string policy_run;
};

bool is_policy_copy_output(const std::string& name) {
  return name == "config.yaml" || name == "checkpoint" || name == "members" || name == "export";
}

// --policy-run DIR: the run's policy-only copy, swapped in whole; the export is then written into
// DIR/export, from DIR, so its README names the copy.
void write_policy_run(const ExportOptions& o) {
  io::StagedFolder folder(o.policy_run, "policy-only copy", is_policy_copy_output);
  train::PolicyCopyReport rep;
  folder.commit([&](const std::string& staging) { rep = train::write_policy_copy(o.run, staging); });
  std::printf("wrote %s: a policy-only copy of %s (%d folder%s, %.2f MB of ll.pt and hl.pt; train --resume refuses it)\n",
              o.policy_run.c_str(), o.run.c_str(), rep.folders, rep.folders == 1 ? "" : "s", rep.bytes / 1e6);
}

void run_export(ExportOptions o) {
  if (!o.policy_run.empty() && !o.out.empty())
    throw io::InputError("--out with --policy-run: the export goes into POLICY_RUN/export; drop --out");
  train::RunPolicy policy = train::load_run_policy(o.run);
  if (policy.config.loop.ll_pilot == train::LowLevelPilot::kAutopilot)
    throw io::InputError(o.run + "/config.yaml: train.ll_pilot is autopilot, so the run's low level is AeroBench's "
                         "waypoint autopilot, not a network: there is nothing to export as TorchScript; race the run "
                         "with f16race tournament or replay");
  if (!o.policy_run.empty()) {
    write_policy_run(o);
    o.run = o.policy_run;
    policy = train::load_run_policy(o.run);  // the export is the copy's, and proves it loads
  }
  const std::string out = o.out.empty() ? o.run + "/export" : o.out;
  // Written into a staging folder beside `out` and swapped in whole: never one export's HL
  // policy beside another's LL policy, and a full disk leaves the earlier export as it was.
  io::StagedFolder folder(out, "export", torchscript::is_export_output);
  torchscript::ExportReport rep;
  folder.commit([&](const std::string& staging) { rep = torchscript::export_policy(policy, staging); });
  std::printf("exported %s (%s, %lld env steps) to %s/\n", policy.name.c_str(),
              agents::es_variant_name(policy.config.hl.variant), static_cast<long long>(policy.env_steps), out.c_str());
  std::printf("  hl_policy.pt  ll_policy.pt  example_io.pt  README.md\n");
  std::printf("  check on %lld random observations: max diff (relative to max(1, |value|)) HL %.2e, LL %.2e, greedy bins %s\n",
              static_cast<long long>(rep.samples), rep.hl_max_diff,
              rep.ll_max_diff,
              !rep.bins_equal      ? "different"
              : rep.bin_ties == 0  ? "identical"
                                   : ("identical but for " + std::to_string(rep.bin_ties) + " ties").c_str());
}

}  // namespace

void add_export_command(CLI::App& app) {
  auto o = std::make_shared<ExportOptions>();
  CLI::App* cmd = app.add_subcommand("export", "Write a trained run's policies as TorchScript (torch.jit.load)");
  cmd->add_option("--run", o->run, "Run folder written by f16race train")->required();
  cmd->add_option("--out", o->out,
                  "Output folder (default: RUN/export), replaced whole by the new export (a folder holding other "
                  "files than an export's is refused)");
  cmd->add_option("--policy-run", o->policy_run,
                  "Also write this folder: a copy of the run without optimiser state (about a third of its "
                  "checkpoint's size) that replay, tournament, export and Python's load_policy read and train "
                  "--resume refuses; the export then goes into its export/ (replaced whole, like --out)");
  cmd->callback([o]() { run_export(*o); });
}

}  // namespace f16race::app
