// SPDX-License-Identifier: MIT
#pragma once
// Transparent huge pages on request (the machines' THP mode is "madvise"):
// the whole 2 MiB pages inside [data, data + bytes) are advised, which must
// happen before they are first touched. Large arrays read at random (pair
// stores, the narrow phase's cache) then cost a fraction of the page walks
// and first-touch faults of 4 KiB pages. Advice only: where the kernel
// declines, pages stay 4 KiB.
#include <sys/mman.h>

#include <cstddef>
#include <cstdint>

namespace hbp {

// The transparent huge page of x86-64.
inline constexpr std::size_t kHugePageBytes = std::size_t{2} << 20;

// bytes rounded up to whole huge pages.
inline constexpr std::size_t whole_huge_pages(std::size_t bytes) {
  return (bytes + kHugePageBytes - 1) / kHugePageBytes * kHugePageBytes;
}

inline void advise_huge_pages(void* data, std::size_t bytes) {
  constexpr std::uintptr_t kMask = kHugePageBytes - 1;
  const auto begin = (reinterpret_cast<std::uintptr_t>(data) + kMask) & ~kMask;
  const auto end = (reinterpret_cast<std::uintptr_t>(data) + bytes) & ~kMask;
  if (end > begin) madvise(reinterpret_cast<void*>(begin), end - begin, MADV_HUGEPAGE);
}

}  // namespace hbp
