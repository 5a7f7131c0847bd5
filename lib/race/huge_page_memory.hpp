#pragma once
// One large, uninitialised allocation backed by transparent huge pages where the kernel
// offers them (Linux MADV_HUGEPAGE; elsewhere plain pages). The race
// env keeps every track of its thousand envs here: with 4 KiB pages each env's track data
// costs its own TLB misses every step (measured: ~6 % of the simulator's time in
// `f16race bench env`), with 2 MiB pages the whole set fits the TLB.
#include <cstddef>

namespace f16race::race {

class HugePageMemory {
 public:
  explicit HugePageMemory(std::size_t bytes);
  ~HugePageMemory();
  HugePageMemory(const HugePageMemory&) = delete;
  HugePageMemory& operator=(const HugePageMemory&) = delete;

  std::byte* data() const { return data_; }
  std::size_t size() const { return size_; }

 private:
  std::byte* data_ = nullptr;
  std::size_t size_ = 0;
};

}  // namespace f16race::race
