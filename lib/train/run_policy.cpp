#include "train/run_policy.hpp"

#include <torch/torch.h>
#include <yaml-cpp/yaml.h>

#include <filesystem>
#include <fstream>
#include <sstream>
#include <stdexcept>

#include "io/yaml_config.hpp"
#include "train/obs_views.hpp"
#include "train/trainer.hpp"

namespace f16race::train {

namespace fs = std::filesystem;

namespace {

std::string folder_name(const std::string& dir) {
  const fs::path p(dir);
  const std::string name = p.filename().string();
  return name.empty() ? p.parent_path().filename().string() : name;
}

RunPolicy make_policy(TrainConfig cfg) {
  RunPolicy p;
  p.dims = obs_dims(cfg.race);
  cfg.ll.net.dims = p.dims;
  cfg.hl.dims = p.dims;
  cfg.ll.total_updates = 1;  // only the learning-rate schedule reads it
  p.config = cfg;
  p.ll = std::make_unique<agents::PpoAgent>(cfg.ll);
  p.hl = std::make_unique<agents::EsAgent>(cfg.hl);
  return p;
}

}  // namespace

TrainConfig read_run_config(const std::string& run_dir) {
  const std::string path = run_dir + "/config.yaml";
  if (!fs::exists(path))
    throw std::runtime_error(run_dir + ": not a training run (no config.yaml); give a folder written by f16race train");
  return read_train_config(io::load_yaml_file(path), path);
}

RunPolicy load_run_policy(const std::string& run_dir) {
  const TrainConfig cfg = read_run_config(run_dir);
  const std::string latest = run_dir + "/checkpoint/LATEST";
  std::ifstream f(latest);
  std::string name;
  if (!(f >> name)) throw std::runtime_error(latest + ": missing, so the run has no checkpoint yet; train it first");
  const fs::path dir = fs::path(run_dir) / "checkpoint" / name;
  RunPolicy p = make_policy(cfg);
  p.name = folder_name(run_dir);
  p.run_dir = run_dir;
  p.checkpoint_dir = dir.string();
  std::string step = "meta.yaml";
  try {
    const YAML::Node meta = YAML::LoadFile((dir / "meta.yaml").string());
    if (meta["format"].as<int>() != kCheckpointFormat)
      throw std::runtime_error("checkpoint format " + meta["format"].as<std::string>() + ", this build reads " +
                               std::to_string(kCheckpointFormat));
    std::ifstream c(run_dir + "/config.yaml");
    std::stringstream text;
    text << c.rdbuf();
    if (meta["config_hash"].as<std::uint64_t>() != config_hash(text.str()))
      throw std::runtime_error("written with a different config.yaml (hash mismatch); restore the run's config.yaml");
    p.env_steps = meta["env_steps"].as<std::int64_t>();
    step = "ll.pt";
    p.ll->load((dir / "ll.pt").string());
    step = "hl.pt";
    p.hl->load((dir / "hl.pt").string());
  } catch (const std::exception& e) {
    std::string what = e.what();
    if (const auto nl = what.find('\n'); nl != std::string::npos) what = what.substr(0, nl);
    throw std::runtime_error((dir / step).string() + ": cannot load the policy: " + what.substr(0, 200));
  }
  return p;
}

RunPolicy untrained_policy(const TrainConfig& config, std::uint64_t seed) {
  torch::manual_seed(seed);  // the initial weights
  RunPolicy p = make_policy(config);
  p.name = "untrained";
  return p;
}

}  // namespace f16race::train
