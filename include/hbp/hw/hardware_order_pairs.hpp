// SPDX-License-Identifier: MIT
#pragma once
// The functional result of each microarchitecture without simulating cycles:
// every overlapping pair, appended in the order the hardware writes its pair
// memory. The fast path of the cell engines, and a reference for the models.
#include <cstdint>
#include <vector>

#include "hbp/box_array.hpp"
#include "hbp/pair.hpp"

namespace hbp::hw {

// Area-efficient order: anchor i ascending, partner j ascending (lexicographic).
// Both stop with CapacityExceeded once more than `max_pairs` pairs were
// appended (checked per anchor row / per step: at most one row beyond).
void area_efficient_order_pairs(const BoxArray& boxes, std::vector<Pair>& out,
                                std::uint64_t max_pairs = ~std::uint64_t{0});
// Many-object order: A address a, then step b = 1.., then comparator k, i.e.
// pair (a*m + k, a*m + k + b).
void many_object_order_pairs(const BoxArray& boxes, std::uint32_t m, std::vector<Pair>& out,
                             std::uint64_t max_pairs = ~std::uint64_t{0});

}  // namespace hbp::hw
