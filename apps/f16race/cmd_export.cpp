// `f16race export`: a trained run's policies as TorchScript modules plain PyTorch can load.
#include <CLI/CLI.hpp>
#include <cstdio>
#include <memory>
#include <string>

#include "commands.hpp"
#include "export/torchscript_export.hpp"
#include "io/input_error.hpp"
#include "io/staged_folder.hpp"
#include "train/run_policy.hpp"

namespace f16race::app {
namespace {

struct ExportOptions {
  std::string run;
  std::string out;
};

void run_export(const ExportOptions& o) {
  train::RunPolicy policy = train::load_run_policy(o.run);
  if (policy.config.loop.ll_pilot == train::LowLevelPilot::kAutopilot)
    throw io::InputError(o.run + "/config.yaml: train.ll_pilot is autopilot, so the run's low level is AeroBench's "
                         "waypoint autopilot, not a network: there is nothing to export as TorchScript; race the run "
                         "with f16race tournament or replay");
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
  cmd->callback([o]() { run_export(*o); });
}

}  // namespace f16race::app
