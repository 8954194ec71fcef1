// SPDX-License-Identifier: MIT
#pragma once
// Closed-form cycle counts of both microarchitectures (O(1) per call). The
// cycle-level simulations must agree with these exactly; tests check it.
#include <cstdint>

#include "hbp/hw/counters.hpp"
#include "hbp/hw/design.hpp"
#include "hbp/hw/model_config.hpp"

namespace hbp::hw {

// Paper, section 3.1.1: sum_{i=0}^{n-2} ceil((n-i-1)/(2m-1)).
std::uint64_t area_efficient_sequence_cycles(std::uint64_t n, std::uint32_t m);
// Paper, section 3.1.2: sum_{i=0}^{ceil(n/m)-1} (n - i*m - 1).
std::uint64_t many_object_sequence_cycles(std::uint64_t n, std::uint32_t m);
// Rows of the many-object sequence that issue at least one cycle:
// A addresses 0 .. ceil((n-1)/m)-1.
std::uint64_t many_object_rows(std::uint64_t n, std::uint32_t m);

// Register stages from address issue to pair line (PipelineLatencies).
std::uint32_t pipeline_depth(Design d, const ModelConfig& cfg);
// Candidate pairs the compare stage evaluates per cycle: 2m-1 or m.
std::uint32_t comparisons_per_cycle(Design d, std::uint32_t m);
// Objects the buffer holds: depth (area-efficient) or depth*m (many-object).
std::uint64_t buffer_capacity(Design d, const ModelConfig& cfg);
// AABBs written per load cycle: min(interface width, what the buffer's
// write ports accept: 2 when replicated, 2m otherwise).
std::uint32_t load_aabbs_per_cycle(Design d, const ModelConfig& cfg);

// Every phase of a run over n objects. Does not check capacity.
CycleBreakdown analytic_cycles(Design d, std::uint64_t n, const ModelConfig& cfg);
// Counters of a run over n objects except pairs_written (data dependent).
Counters analytic_counters(Design d, std::uint64_t n, const ModelConfig& cfg);

}  // namespace hbp::hw
