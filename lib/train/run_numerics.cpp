#include "train/run_numerics.hpp"

#include <yaml-cpp/yaml.h>

#include <cstdio>
#include <filesystem>

#include "io/input_error.hpp"
#include "io/json_text.hpp"
#include "io/provenance.hpp"
#include "train/trainer.hpp"

namespace f16race::train {

namespace fs = std::filesystem;

std::string numerics_meta_lines() {
  const io::RunNumerics self = io::this_numerics();
  std::string lines = "numerics: " + self.mode + "\n";
  if (!self.cpu.empty()) lines += "cpu: " + io::json_string(self.cpu) + "\n";  // a JSON string is YAML too
  return lines;
}

io::RunNumerics checkpoint_numerics(const std::string& checkpoint_dir) {
  const std::string path = checkpoint_dir + "/meta.yaml";
  io::RunNumerics n;
  YAML::Node meta;
  try {
    meta = YAML::LoadFile(path);
  } catch (const YAML::Exception& e) {
    throw io::InputError(path + ": cannot read the checkpoint's record (" + e.what() +
                         "); restore the file as f16race train wrote it");
  }
  if (!meta.IsMap() || !meta["numerics"]) return n;
  n.mode = meta["numerics"].Scalar();
  if (n.mode != "reproducible" && n.mode != "native")
    throw io::InputError(path + ": numerics is '" + n.mode + "', not reproducible or native; restore the file as " +
                         "f16race train wrote it");
  if (meta["cpu"]) n.cpu = meta["cpu"].Scalar();
  n.recorded = true;
  return n;
}

io::RunNumerics run_numerics(const std::string& run_dir) {
  const std::string latest = latest_checkpoint_name(run_dir);
  if (latest.empty()) return io::RunNumerics{};
  return checkpoint_numerics((fs::path(run_dir) / "checkpoint" / latest).string());
}

void check_resume_numerics(const std::string& run_dir) {
  const io::RunNumerics run = run_numerics(run_dir), self = io::this_numerics();
  if (io::numerics_difference(run, self).empty()) return;
  const bool run_native = !run.recorded || run.mode == "native";
  if (run_native && self.mode == "native") {
    std::fprintf(stderr, "f16race: warning: %s was trained %s; resumed on %s, its bytes from here on are this CPU's\n",
                 run_dir.c_str(), io::describe(run).c_str(), io::cpu_model().c_str());
    return;
  }
  throw io::InputError(run_dir + " was trained " + io::describe(run) + " and this f16race is a " + self.mode +
                       " build: resuming would mix two modes' kernels in one run; resume it with a " +
                       (run_native ? "native build (F16RACE_ARCH=native scripts/build.sh)"
                                   : "reproducible build (scripts/build.sh)") +
                       ", or train it again");
}

}  // namespace f16race::train
