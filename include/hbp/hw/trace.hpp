// SPDX-License-Identifier: MIT
#pragma once
// Per-cycle traces of the two models: one record per cycle that issues buffer
// addresses (load, restart and drain cycles issue none; their absence shows as
// gaps in `cycle`). Meant for verification and teaching, not for speed.
#include <cstdint>
#include <vector>

namespace hbp::hw {

// One comparator slot: the two objects whose data met in the compare stage.
// `valid` is false when a slot touches an object index >= n: the hardware
// still evaluates it, the result is discarded.
struct SlotComparison {
  std::uint32_t anchor = 0;   // object on the fixed side (port 0A / an A port)
  std::uint32_t partner = 0;  // object on the moving side
  bool valid = false;
  bool collided = false;  // only meaningful when valid
};

// Area-efficient: ports in the paper's order 0A, 0B, 1A, 1B, ..., (m-1)B.
// Port p belongs to memory group p / 2; slot s compares port 0A with port s+1.
struct AreaEfficientCycle {
  std::uint64_t cycle = 0;  // 1-based, counting from the first modelled cycle
  std::vector<std::uint32_t> port_address;  // 2m addresses (may be >= n)
  std::vector<SlotComparison> comparisons;  // 2m-1 slots
};

// Many-object: per memory group j the A and B port addresses and the object
// they return (address * m + j); per comparator k the multiplexer selector
// (comparator k pairs group k's A data with group selector[k]'s B data).
struct ManyObjectCycle {
  std::uint64_t cycle = 0;
  std::vector<std::uint32_t> a_address, b_address;  // m each
  std::vector<std::uint32_t> a_object, b_object;    // m each (may be >= n)
  std::vector<std::uint32_t> selector;              // m
  std::vector<SlotComparison> comparisons;          // m slots
};

using AreaEfficientTrace = std::vector<AreaEfficientCycle>;
using ManyObjectTrace = std::vector<ManyObjectCycle>;

}  // namespace hbp::hw
