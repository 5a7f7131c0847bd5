#pragma once
// Private to lib/train: the two sides of Trainer::State::visit_checkpoint (trainer.pt). Each key
// is written by one and read back by the other from the same list, so saving and loading cannot
// drift apart.
#include <torch/torch.h>

#include <cstdint>
#include <cstring>
#include <functional>
#include <istream>
#include <ostream>
#include <sstream>
#include <string>
#include <vector>

namespace f16race::train {

inline torch::Tensor bytes_tensor(const std::string& bytes) {
  auto t = torch::empty({static_cast<std::int64_t>(bytes.size())}, torch::kUInt8);
  std::memcpy(t.data_ptr(), bytes.data(), bytes.size());
  return t;
}

inline std::string tensor_bytes(const torch::Tensor& t) {
  const auto c = t.contiguous();
  return std::string(static_cast<const char*>(c.data_ptr()), static_cast<std::size_t>(c.numel()));
}

struct CheckpointWriter {
  torch::serialize::OutputArchive a;
  void tensor(const char* key, torch::Tensor& t) { a.write(key, t); }
  template <class... T>
  void integers(const char* key, T&... x) {
    a.write(key, torch::tensor(std::vector<std::int64_t>{static_cast<std::int64_t>(x)...}));
  }
  // Double precision explicitly: torch::tensor of doubles would default to float32.
  template <class... T>
  void reals(const char* key, T&... x) {
    a.write(key, torch::tensor(std::vector<double>{x...}, torch::kFloat64));
  }
  template <class T>
  void integer_list(const char* key, std::vector<T>& v, bool /*fixed_size*/) {
    a.write(key, torch::tensor(std::vector<std::int64_t>(v.begin(), v.end()), torch::kInt64));
  }
  template <class... T>
  void optional_reals(const char* key, T&... x) {
    reals(key, x...);
  }
  void real_list(const char* key, std::vector<double>& v) { a.write(key, torch::tensor(v, torch::kFloat64)); }
  void bytes(const char* key, const std::function<void(std::ostream&)>& save, const std::function<void(std::istream&)>&) {
    std::ostringstream out;
    save(out);
    a.write(key, bytes_tensor(out.str()));
  }
};

struct CheckpointReader {
  torch::serialize::InputArchive a;
  // A fresh tensor per key: reading into a defined tensor would reuse (and reinterpret) it.
  torch::Tensor get(const char* key, std::int64_t want_numel = -1) {
    torch::Tensor t;
    a.read(key, t);
    TORCH_CHECK(want_numel < 0 || t.numel() == want_numel, "'", key, "' holds ", t.numel(), " values, expected ",
                want_numel, " (another config?)");
    return t;
  }
  void tensor(const char* key, torch::Tensor& t) { t.copy_(get(key, t.numel())); }
  template <class... T>
  void integers(const char* key, T&... x) {
    const torch::Tensor t = get(key, sizeof...(T)).to(torch::kInt64).contiguous();
    const std::int64_t* p = t.data_ptr<std::int64_t>();
    std::size_t k = 0;
    ((x = static_cast<T>(p[k++])), ...);
  }
  template <class... T>
  void reals(const char* key, T&... x) {
    const torch::Tensor t = get(key, sizeof...(T)).to(torch::kFloat64).contiguous();
    const double* p = t.data_ptr<double>();
    std::size_t k = 0;
    ((x = p[k++]), ...);
  }
  // A key newer than some checkpoints: absent, the values are left as they are.
  template <class... T>
  void optional_reals(const char* key, T&... x) {
    torch::Tensor t;
    if (!a.try_read(key, t)) return;
    TORCH_CHECK(t.numel() == static_cast<std::int64_t>(sizeof...(T)), "'", key, "' holds ", t.numel(),
                " values, expected ", sizeof...(T));
    t = t.to(torch::kFloat64).contiguous();
    const double* p = t.data_ptr<double>();
    std::size_t k = 0;
    ((x = p[k++]), ...);
  }
  template <class T>
  void integer_list(const char* key, std::vector<T>& v, bool fixed_size) {
    const torch::Tensor t = get(key, fixed_size ? static_cast<std::int64_t>(v.size()) : -1).to(torch::kInt64).contiguous();
    const std::int64_t* p = t.data_ptr<std::int64_t>();
    v.assign(p, p + t.numel());
  }
  void real_list(const char* key, std::vector<double>& v) {
    const torch::Tensor t = get(key, static_cast<std::int64_t>(v.size())).to(torch::kFloat64).contiguous();
    v.assign(t.data_ptr<double>(), t.data_ptr<double>() + t.numel());
  }
  void bytes(const char* key, const std::function<void(std::ostream&)>&, const std::function<void(std::istream&)>& load) {
    std::istringstream in(tensor_bytes(get(key)));
    load(in);
  }
};

}  // namespace f16race::train
