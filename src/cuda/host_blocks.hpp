// SPDX-License-Identifier: MIT
#pragma once
// The CPU launcher's grid: blocks [0, count) split into one contiguous
// range per thread. Each block writes only its own slots, so the result is
// the same for any thread count (as on the device, where blocks run in any
// order).
#include <algorithm>
#include <cstdint>
#include <thread>
#include <vector>

namespace hbp::cuda {

template <class Fn>
void for_blocks(unsigned threads, std::uint64_t count, Fn&& fn) {
  const std::uint64_t workers = std::min<std::uint64_t>(threads, count / 1024 + 1);
  if (workers <= 1) {
    for (std::uint64_t b = 0; b < count; ++b) fn(b);
    return;
  }
  std::vector<std::jthread> pool;
  pool.reserve(workers - 1);
  const auto range = [&](std::uint64_t w) {
    const std::uint64_t lo = count * w / workers, hi = count * (w + 1) / workers;
    for (std::uint64_t b = lo; b < hi; ++b) fn(b);
  };
  for (std::uint64_t w = 1; w < workers; ++w) pool.emplace_back(range, w);
  range(0);
}

}  // namespace hbp::cuda
