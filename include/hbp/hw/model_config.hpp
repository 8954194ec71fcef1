// SPDX-License-Identifier: MIT
#pragma once
// Configuration shared by the two cycle-accurate microarchitecture models
// (paper section 3.1): extensibility factor, memory depth, clock, pipeline
// latencies and the two timing conventions the paper leaves open. Every
// default is explained in docs/hardware-models.md.
#include <cstdint>

namespace hbp::hw {

// Register stages between issuing an address to the buffer and the pair
// line being written. Chosen for a 500 MHz float32 datapath: block RAM with
// an output register, one stage per 6m-input multiplexer level, a two-stage
// floating-point comparator (magnitude compare, then sign fix-up).
struct PipelineLatencies {
  std::uint32_t memory_read = 2;  // RAM array + output register
  std::uint32_t reorder = 1;      // many-object only: the 6m multiplexers
  std::uint32_t compare = 2;      // >= and <= comparators
  std::uint32_t and_gate = 1;     // the 6-input AND per candidate pair
  std::uint32_t pair_write = 1;   // one line per pair into the output memory
};

struct ModelConfig {
  std::uint32_t m = 16;        // extensibility factor, 1..64
  std::uint32_t depth = 1024;  // words per dual-port memory
  double clock_hz = 500e6;
  PipelineLatencies latency{};
  // Width of the interface that loads the buffer, in AABBs per cycle. The
  // buffer itself may accept fewer: the area-efficient buffer replicates every
  // AABB into all m memory groups, so its two ports per memory cap it at 2.
  std::uint32_t load_aabbs_per_cycle = 2;
  // Whether loading the n AABBs is on the modelled clock. Off by default:
  // the paper's timings exclude moving data into the accelerator, and the
  // area-efficient column of Table 4 is too fast to contain a load that the
  // replicated buffer can physically perform (docs/hardware-models.md).
  bool count_load = false;
  // Many-object only: the sequencer lets the pipeline empty before it changes
  // the A address (the comparators' A operands and the multiplexer selectors
  // restart with the row). Costs one pipeline depth per row; this is what
  // Table 4's many-object column shows.
  bool row_change_drains_pipeline = true;
};

inline constexpr std::uint32_t kMaxExtensibility = 64;

// Throws InvalidInput naming the offending field (m outside 1..64, depth 0,
// clock not positive and finite, load width 0).
void validate(const ModelConfig& cfg);

}  // namespace hbp::hw
