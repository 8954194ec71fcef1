#pragma once
// The order of a cell's boxes by increasing min x (ties by index), which the
// sweep kernel needs. Radix sort on the float's order-preserving bit pattern:
// linear in the cell size, no comparisons, no allocation once warmed up.
#include <bit>
#include <cstdint>
#include <vector>

namespace hbp {

// Order-preserving map from float to unsigned (negatives flipped; -0 sorts
// before +0, which is harmless: equal values may come in either order, as
// long as the choice is deterministic).
inline std::uint32_t min_x_key(float f) {
  const auto u = std::bit_cast<std::uint32_t>(f);
  return (u & 0x80000000u) ? ~u : (u | 0x80000000u);
}

// True when min_x is already in the order min_x_order() would produce
// (non-decreasing keys): the sort can be skipped.
bool in_min_x_order(const float* min_x, std::uint32_t n);

void min_x_order(const float* min_x, std::uint32_t n, std::vector<std::uint32_t>& order,
                 std::vector<std::uint64_t>& scratch);

}  // namespace hbp
