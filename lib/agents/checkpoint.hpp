#pragma once
// Checkpoint helpers shared by the agents: atomic archive writes and generator state.
#include <torch/torch.h>

#include <sstream>
#include <string>

#include "io/atomic_file.hpp"

namespace f16race::agents {

// Serialises `archive` in memory, then writes it with io::write_file_atomic: a crash or a full
// disk mid-write leaves the old checkpoint (or none) and an io::FileWriteError, never a
// truncated file or LibTorch's backtrace.
inline void save_archive_atomic(torch::serialize::OutputArchive& archive, const std::string& path) {
  std::ostringstream bytes;
  archive.save_to(bytes);
  io::write_file_atomic(path, bytes.str());
}

inline void write_module(torch::serialize::OutputArchive& root, const std::string& key, const torch::nn::Module& m) {
  torch::serialize::OutputArchive sub;
  m.save(sub);
  root.write(key, sub);
}

inline void read_module(torch::serialize::InputArchive& root, const std::string& key, torch::nn::Module& m) {
  torch::serialize::InputArchive sub;
  root.read(key, sub);
  m.load(sub);
}

inline void write_optimizer(torch::serialize::OutputArchive& root, const std::string& key,
                            const torch::optim::Optimizer& opt) {
  torch::serialize::OutputArchive sub;
  opt.save(sub);
  root.write(key, sub);
}

inline void read_optimizer(torch::serialize::InputArchive& root, const std::string& key, torch::optim::Optimizer& opt) {
  torch::serialize::InputArchive sub;
  root.read(key, sub);
  opt.load(sub);
}

inline int64_t read_int(torch::serialize::InputArchive& root, const std::string& key) {
  torch::Tensor t;
  root.read(key, t);
  return t.item<int64_t>();
}

// What every agent saves beside its networks: the observation normaliser, the optimiser, the
// update counter and the minibatch generator, so a resumed agent continues exactly.
inline void write_agent_state(torch::serialize::OutputArchive& root, const torch::nn::Module& normalizer,
                              const torch::optim::Optimizer& opt, int64_t update_count, const at::Generator& generator) {
  write_module(root, "normalizer", normalizer);
  write_optimizer(root, "optimizer", opt);
  root.write("update_count", torch::tensor(update_count));
  root.write("generator_state", generator.get_state());
}

inline void read_agent_state(torch::serialize::InputArchive& root, torch::nn::Module& normalizer,
                             torch::optim::Optimizer& opt, int64_t* update_count, at::Generator& generator) {
  read_module(root, "normalizer", normalizer);
  read_optimizer(root, "optimizer", opt);
  *update_count = read_int(root, "update_count");
  torch::Tensor state;
  root.read("generator_state", state);
  generator.set_state(state);
}

}  // namespace f16race::agents
