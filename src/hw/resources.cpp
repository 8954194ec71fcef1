// SPDX-License-Identifier: MIT
#include "hbp/hw/resources.hpp"

namespace hbp::hw {

Resources resources(Design d, const ModelConfig& cfg) {
  Resources r;
  const std::uint32_t m = cfg.m;
  r.memories = 6 * m;
  r.memory_bits = static_cast<std::uint64_t>(r.memories) * cfg.depth * 32;
  r.read_ports = 2 * r.memories;
  // Six comparators (three >=, three <=) and one AND gate per candidate pair.
  const std::uint32_t pairs_per_cycle = d == Design::AreaEfficient ? 2 * m - 1 : m;
  r.ge_comparators = 3 * pairs_per_cycle;
  r.le_comparators = 3 * pairs_per_cycle;
  r.and_gates = pairs_per_cycle;
  if (d == Design::ManyObject) {
    r.multiplexers = 6 * m;  // one per B-side memory, selecting among m groups
    r.multiplexer_inputs = m;
  }
  return r;
}

}  // namespace hbp::hw
