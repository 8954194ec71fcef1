// SPDX-License-Identifier: MIT
#pragma once
// How fast this machine's memory answers right now: the mean time of a
// dependent random load (one per 64-byte line, a single cycle over the
// buffer) over a buffer that fits a server's last-level cache and one that
// does not. On a shared virtual machine the first swings with what the
// neighbours do to the shared cache (on the 2-core AMD EPYC VM of
// docs/results.md from about 30 ns, the cache ours, to 80-150 ns within
// minutes), and every memory-bound timing swings with it: `hbp bench`
// records it before and after a run, so two runs' figures can be read side
// by side.
#include <string>

namespace hbp::cli {

struct MemoryLatency {
  double cache_ns = 0;   // over kCacheProbeMiB
  double memory_ns = 0;  // over kMemoryProbeMiB
};

inline constexpr unsigned kCacheProbeMiB = 8;
inline constexpr unsigned kMemoryProbeMiB = 32;

// About 0.1-0.3 s (most of it the larger buffer's page faults).
MemoryLatency probe_memory_latency();

// "31 ns over 8 MiB, 160 ns over 32 MiB (dependent random loads)".
std::string memory_latency_text(const MemoryLatency& m);

}  // namespace hbp::cli
