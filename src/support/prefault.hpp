// SPDX-License-Identifier: MIT
#pragma once
// Fresh pages faulted in from every worker at once. The kernel zeroes each
// page on first touch (on our VMs well under 1 GB/s a thread, and 2.3 ms a
// MB when the host has reclaimed free memory: docs/hybrid-system.md, "First
// frame and rebuilds"); a buffer written afterwards by one thread, or whose
// first writer is a later frame, would take every fault there. One write
// per 4 KiB page, in 2 MiB chunks (a huge page each where advised). The
// contents are left undefined: only for storage about to be overwritten.
#include <algorithm>
#include <cstddef>

#include "support/huge_pages.hpp"
#include "support/parallel_for.hpp"

namespace hbp {

inline void prefault_pages(void* data, std::size_t bytes) {
  constexpr std::size_t kChunk = kHugePageBytes;
  constexpr std::size_t kPage = 4096;
  auto* const base = static_cast<volatile unsigned char*>(data);
  const std::size_t chunks = (bytes + kChunk - 1) / kChunk;
  detail::parallel_for_each(chunks, [&](std::size_t k) {
    const std::size_t end = std::min(bytes, (k + 1) * kChunk);
    for (std::size_t at = k * kChunk; at < end; at += kPage) base[at] = 0;
  });
}

}  // namespace hbp
