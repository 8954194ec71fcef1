// SPDX-License-Identifier: MIT
#pragma once
// The order of a cell's boxes by increasing min x (ties by index), which the
// sweep kernel needs. The radix sort of src/support/radix_sort.hpp on the
// float's order-preserving bit pattern: linear in the cell size, no
// comparisons, no allocation once warmed up.
#include <cstdint>
#include <vector>

namespace hbp {

// True when min_x is already in the order min_x_order() would produce
// (non-decreasing keys): the sort can be skipped.
bool in_min_x_order(const float* min_x, std::uint32_t n);

void min_x_order(const float* min_x, std::uint32_t n, std::vector<std::uint32_t>& order,
                 std::vector<std::uint64_t>& scratch);

}  // namespace hbp
