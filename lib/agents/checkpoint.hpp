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

// A module or an optimizer as a sub-archive under `key`: both have save/load on archives.
template <class Saveable>
void write_sub_archive(torch::serialize::OutputArchive& root, const std::string& key, const Saveable& part) {
  torch::serialize::OutputArchive sub;
  part.save(sub);
  root.write(key, sub);
}

template <class Loadable>
void read_sub_archive(torch::serialize::InputArchive& root, const std::string& key, Loadable& part) {
  torch::serialize::InputArchive sub;
  root.read(key, sub);
  part.load(sub);
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
  write_sub_archive(root, "normalizer", normalizer);
  write_sub_archive(root, "optimizer", opt);
  root.write("update_count", torch::tensor(update_count));
  root.write("generator_state", generator.get_state());
}

inline void read_agent_state(torch::serialize::InputArchive& root, torch::nn::Module& normalizer,
                             torch::optim::Optimizer& opt, int64_t* update_count, at::Generator& generator) {
  read_sub_archive(root, "normalizer", normalizer);
  read_sub_archive(root, "optimizer", opt);
  *update_count = read_int(root, "update_count");
  torch::Tensor state;
  root.read("generator_state", state);
  generator.set_state(state);
}

}  // namespace f16race::agents
