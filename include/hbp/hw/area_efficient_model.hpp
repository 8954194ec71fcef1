// SPDX-License-Identifier: MIT
#pragma once
// Cycle-accurate model of the area-efficient microarchitecture (paper section
// 3.1.1, Table 1). Buffer: 6m dual-port memories in m memory groups, each
// group holding a full copy of the n AABBs, so 2m ports read 2m objects per
// cycle. Sequence: port 0A holds anchor i, the other 2m-1 ports hold the next
// 2m-1 addresses and all step by 2m-1 until one selects n-1; then the anchor
// advances. Compare: 6m-3 >= and 6m-3 <= comparators feeding 2m-1 six-input
// AND gates, anchor against each other port; slots reading an address >= n
// are discarded. Each colliding pair is one line of the pair output memory.
#include <cstdint>
#include <vector>

#include "hbp/box_array.hpp"
#include "hbp/hw/buffer_model.hpp"
#include "hbp/hw/trace.hpp"
#include "hbp/pair.hpp"

namespace hbp::hw {

class AreaEfficientModel : public BufferModel {
 public:
  explicit AreaEfficientModel(const ModelConfig& cfg = {});

  // Objects the buffer holds: `depth` (every group stores all of them).
  std::uint32_t capacity() const { return cfg_.depth; }

  // Loads `boxes` into the buffer, runs the sequence cycle by cycle and
  // appends each colliding pair (i < j) to `pair_memory` in the order the
  // hardware writes them. Records every issuing cycle into `trace` if given.
  // Throws CapacityExceeded when boxes.size() > capacity(), or as soon as
  // more than pair_limit() pairs have reached `pair_memory` in this run (a
  // pair explosion stops within one cycle's lines of the limit instead of
  // filling memory); InvalidInput naming the object when a coordinate is NaN.
  Counters run(const BoxArray& boxes, std::vector<Pair>& pair_memory,
               AreaEfficientTrace* trace = nullptr);

 private:
  void load(const BoxArray& boxes);

  std::vector<AabbWords> port_data_;  // the 2m words read this cycle
};

}  // namespace hbp::hw
