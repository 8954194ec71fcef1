// SPDX-License-Identifier: MIT
#pragma once
// The pair limit of one engine call (CellEngine::pair_limit, the hybrid
// system's max_pairs): the models and the hardware-order loops stop with
// CapacityExceeded as soon as a call has appended more pairs than that, so a
// pair explosion inside one cell never grows past the limit in memory.
#include <cstddef>
#include <cstdint>

namespace hbp::hw {

// Throws CapacityExceeded (naming the cell size and the limit) when
// `appended` > `max_pairs`.
void check_pair_limit(std::size_t appended, std::uint64_t max_pairs, std::uint32_t n);

}  // namespace hbp::hw
