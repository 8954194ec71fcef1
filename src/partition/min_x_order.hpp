#pragma once
// The order of a cell's boxes by increasing min x (ties by index), which the
// sweep kernel needs. Radix sort on the float's order-preserving bit pattern:
// linear in the cell size, no comparisons, no allocation once warmed up.
#include <cstdint>
#include <vector>

namespace hbp {

void min_x_order(const float* min_x, std::uint32_t n, std::vector<std::uint32_t>& order,
                 std::vector<std::uint64_t>& scratch);

}  // namespace hbp
