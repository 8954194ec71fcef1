// SPDX-License-Identifier: MIT
#pragma once
// What a microarchitecture refuses before loading its buffer: more objects
// than it holds (CapacityExceeded) and NaN coordinates, which its comparators
// do not order (InvalidInput). Messages name the design, configuration and
// the offending object.
#include <cstdint>

#include "hbp/box_array.hpp"
#include "hbp/hw/design.hpp"
#include "hbp/hw/model_config.hpp"

namespace hbp::hw {

void check_capacity(Design d, const ModelConfig& cfg, std::uint64_t n);
void check_buffer_input(Design d, const ModelConfig& cfg, const BoxArray& boxes);

}  // namespace hbp::hw
