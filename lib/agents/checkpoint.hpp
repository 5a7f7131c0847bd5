#pragma once
// Checkpoint helpers shared by the agents: atomic archive writes and generator state.
#include <torch/torch.h>

#include <memory>
#include <sstream>
#include <stdexcept>
#include <string>
#include <tuple>

#include "agents/checkpoint_content.hpp"
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

// Adam's state by position (group g, parameter k) instead of LibTorch's own format, which keys
// it by each parameter's TensorImpl address and stores it in hash-map order: the same run wrote
// different bytes in every process. Written so, a checkpoint's bytes depend only on the run.
inline void write_adam(torch::serialize::OutputArchive& root, const std::string& key, const torch::optim::Adam& opt) {
  torch::serialize::OutputArchive sub;
  const auto& groups = opt.param_groups();
  sub.write("n_groups", torch::tensor(static_cast<int64_t>(groups.size())));
  for (std::size_t g = 0; g < groups.size(); ++g) {
    const std::string gk = "group" + std::to_string(g) + "/";
    const auto& o = static_cast<const torch::optim::AdamOptions&>(groups[g].options());
    sub.write(gk + "options", torch::tensor({o.lr(), std::get<0>(o.betas()), std::get<1>(o.betas()), o.eps(),
                                             o.weight_decay(), o.amsgrad() ? 1.0 : 0.0},
                                            torch::kFloat64));
    const auto& params = groups[g].params();
    sub.write(gk + "n_params", torch::tensor(static_cast<int64_t>(params.size())));
    for (std::size_t k = 0; k < params.size(); ++k) {
      const std::string pk = gk + "param" + std::to_string(k) + "/";
      const auto it = opt.state().find(c10::guts::to_string(params[k].unsafeGetTensorImpl()));
      sub.write(pk + "has_state", torch::tensor(it != opt.state().end() ? int64_t{1} : int64_t{0}));
      if (it == opt.state().end()) continue;  // never stepped
      const auto& st = static_cast<const torch::optim::AdamParamState&>(*it->second);
      sub.write(pk + "step", torch::tensor(st.step()));
      sub.write(pk + "exp_avg", st.exp_avg());
      sub.write(pk + "exp_avg_sq", st.exp_avg_sq());
      if (st.max_exp_avg_sq().defined()) sub.write(pk + "max_exp_avg_sq", st.max_exp_avg_sq());
    }
  }
  root.write(key, sub);
}

// Reads write_adam's sub-archive `key`; a checkpoint written before it (LibTorch's format under
// "optimizer") still loads. Throws std::runtime_error when the archive's parameter layout is not
// this optimizer's.
inline void read_adam(torch::serialize::InputArchive& root, const std::string& key, torch::optim::Adam& opt) {
  torch::serialize::InputArchive sub;
  if (!root.try_read(key, sub)) {
    read_sub_archive(root, "optimizer", opt);
    return;
  }
  auto& groups = opt.param_groups();
  if (read_int(sub, "n_groups") != static_cast<int64_t>(groups.size()))
    throw std::runtime_error("optimizer state: parameter groups do not match this network");
  for (std::size_t g = 0; g < groups.size(); ++g) {
    const std::string gk = "group" + std::to_string(g) + "/";
    torch::Tensor o;
    sub.read(gk + "options", o);
    const auto v = o.accessor<double, 1>();
    auto& opts = static_cast<torch::optim::AdamOptions&>(groups[g].options());
    opts.lr(v[0]).betas(std::make_tuple(v[1], v[2])).eps(v[3]).weight_decay(v[4]).amsgrad(v[5] != 0.0);
    const auto& params = groups[g].params();
    if (read_int(sub, gk + "n_params") != static_cast<int64_t>(params.size()))
      throw std::runtime_error("optimizer state: parameters do not match this network");
    for (std::size_t k = 0; k < params.size(); ++k) {
      const std::string pk = gk + "param" + std::to_string(k) + "/";
      const std::string state_key = c10::guts::to_string(params[k].unsafeGetTensorImpl());
      if (read_int(sub, pk + "has_state") == 0) {
        opt.state().erase(state_key);
        continue;
      }
      auto st = std::make_unique<torch::optim::AdamParamState>();
      st->step(read_int(sub, pk + "step"));
      torch::Tensor t;
      sub.read(pk + "exp_avg", t);
      st->exp_avg(t);
      torch::Tensor t2;
      sub.read(pk + "exp_avg_sq", t2);
      st->exp_avg_sq(t2);
      torch::Tensor t3;
      if (sub.try_read(pk + "max_exp_avg_sq", t3)) st->max_exp_avg_sq(t3);
      if (!t.sizes().equals(params[k].sizes()) || !t2.sizes().equals(params[k].sizes()))
        throw std::runtime_error("optimizer state: a parameter's shape does not match this network");
      opt.state()[state_key] = std::move(st);
    }
  }
}

// What every agent saves beside its networks: the observation normaliser, the optimiser (kFull
// only; a kPolicy file says so under "policy_only"), the update counter and the minibatch
// generator, so a resumed agent continues exactly.
inline void write_agent_state(torch::serialize::OutputArchive& root, const torch::nn::Module& normalizer,
                              const torch::optim::Adam& opt, int64_t update_count, const at::Generator& generator,
                              CheckpointContent content) {
  write_sub_archive(root, "normalizer", normalizer);
  if (content == CheckpointContent::kFull)
    write_adam(root, "adam", opt);
  else
    root.write("policy_only", torch::tensor(int64_t{1}));
  root.write("update_count", torch::tensor(update_count));
  root.write("generator_state", generator.get_state());
}

// Reads write_agent_state's parts; returns whether the file is policy-only (the optimiser then
// keeps its fresh state).
inline CheckpointContent read_agent_state(torch::serialize::InputArchive& root, torch::nn::Module& normalizer,
                                          torch::optim::Adam& opt, int64_t* update_count, at::Generator& generator) {
  read_sub_archive(root, "normalizer", normalizer);
  torch::Tensor flag;
  const bool policy_only = root.try_read("policy_only", flag);
  if (!policy_only) read_adam(root, "adam", opt);
  *update_count = read_int(root, "update_count");
  torch::Tensor state;
  root.read("generator_state", state);
  generator.set_state(state);
  return policy_only ? CheckpointContent::kPolicy : CheckpointContent::kFull;
}

}  // namespace f16race::agents
