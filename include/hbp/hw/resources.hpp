// SPDX-License-Identifier: MIT
#pragma once
// Datapath resources of each microarchitecture for a configuration (paper
// sections 3.1.1 and 3.1.2): what an architect sizes against an area budget.
#include <cstdint>

#include "hbp/hw/design.hpp"
#include "hbp/hw/model_config.hpp"

namespace hbp::hw {

struct Resources {
  std::uint32_t memories = 0;          // dual-port, one per coordinate and group
  std::uint64_t memory_bits = 0;       // memories x depth x 32
  std::uint32_t read_ports = 0;        // two per memory
  std::uint32_t ge_comparators = 0;    // float32 >=
  std::uint32_t le_comparators = 0;    // float32 <=
  std::uint32_t and_gates = 0;         // six inputs each
  std::uint32_t multiplexers = 0;      // reorder stage (many-object)
  std::uint32_t multiplexer_inputs = 0;  // data inputs per multiplexer
};

Resources resources(Design d, const ModelConfig& cfg);

}  // namespace hbp::hw
