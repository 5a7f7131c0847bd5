#include "race/huge_page_memory.hpp"

#include <algorithm>
#include <cstdlib>
#include <new>

#if defined(__linux__)
#include <sys/mman.h>
#endif

namespace f16race::race {

namespace {
constexpr std::size_t kHugePage = std::size_t{2} << 20;
}

HugePageMemory::HugePageMemory(std::size_t bytes) {
  size_ = (std::max<std::size_t>(bytes, 1) + kHugePage - 1) / kHugePage * kHugePage;
  void* p = std::aligned_alloc(kHugePage, size_);
  if (p == nullptr) throw std::bad_alloc();
#if defined(MADV_HUGEPAGE)
  madvise(p, size_, MADV_HUGEPAGE);  // advice only: without THP the memory works the same
#endif
  data_ = static_cast<std::byte*>(p);
}

HugePageMemory::~HugePageMemory() { std::free(data_); }

}  // namespace f16race::race
