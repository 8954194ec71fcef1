// SPDX-License-Identifier: MIT
#include "memory_probe.hpp"

#include <chrono>
#include <cstddef>
#include <cstdint>
#include <cstdio>
#include <numeric>
#include <utility>
#include <vector>

#include "support/random.hpp"

namespace hbp::cli {

namespace {

constexpr std::size_t kLineWords = 64 / sizeof(std::uint64_t);

// Mean ns of `loads` dependent loads around a random single cycle through
// the 64-byte lines of a buffer of `mib` MiB (Sattolo's shuffle: one cycle,
// so the chase does not settle into a short loop that stays in cache).
double chase_ns(unsigned mib, std::size_t loads) {
  const std::size_t lines = std::size_t{mib} << 20 >> 6;
  std::vector<std::uint32_t> order(lines);
  std::iota(order.begin(), order.end(), 0u);
  Random rng(0x5eed);  // the same walk every run
  for (std::size_t i = lines - 1; i > 0; --i) std::swap(order[i], order[rng.below(static_cast<std::uint32_t>(i))]);
  // 4 KiB pages, as most callers' arrays are: on this VM a buffer on 2 MiB
  // pages did not tell the states apart (89-122 ns over 8 MiB in runs where
  // this one read 22-28 ns).
  std::vector<std::uint64_t> memory(lines * kLineWords);
  std::uint64_t* const buffer = memory.data();
  for (std::size_t i = 0; i < lines; ++i) buffer[std::size_t{order[i]} * kLineWords] = order[(i + 1) % lines];
  std::uint64_t at = 0;
  for (std::size_t k = 0; k < loads / 8; ++k) at = buffer[at * kLineWords];  // untimed start
  const auto t0 = std::chrono::steady_clock::now();
  for (std::size_t k = 0; k < loads; ++k) at = buffer[at * kLineWords];
  const double ns = std::chrono::duration<double, std::nano>(std::chrono::steady_clock::now() - t0).count();
  // The walk's end is used, so the loads cannot be dropped.
  volatile std::uint64_t sink = at;
  (void)sink;
  return ns / static_cast<double>(loads);
}

}  // namespace

MemoryLatency probe_memory_latency() {
  MemoryLatency m;
  m.cache_ns = chase_ns(kCacheProbeMiB, 400'000);
  m.memory_ns = chase_ns(kMemoryProbeMiB, 200'000);
  return m;
}

std::string memory_latency_text(const MemoryLatency& m) {
  char text[128];
  std::snprintf(text, sizeof text, "%.0f ns over %u MiB, %.0f ns over %u MiB (dependent random loads)", m.cache_ns,
                kCacheProbeMiB, m.memory_ns, kMemoryProbeMiB);
  return text;
}

}  // namespace hbp::cli
