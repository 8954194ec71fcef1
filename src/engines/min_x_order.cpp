// SPDX-License-Identifier: MIT
#include "engines/min_x_order.hpp"

#include "support/radix_sort.hpp"

namespace hbp {

bool in_min_x_order(const float* min_x, std::uint32_t n) {
  // No early exit: a branch-free pass vectorises and the cells are small.
  // Plain float <= orders like float_order_key (-0 == +0; boxes are checked
  // for NaN before they get here). An int OR of the failures: GCC 12
  // vectorises this form, not a bool AND of the passes (which ran as scalar
  // compares and branches, ~10 instructions a box).
  int unsorted = 0;
  for (std::uint32_t i = 1; i < n; ++i) unsorted |= !(min_x[i - 1] <= min_x[i]);
  return unsorted == 0;
}

void min_x_order(const float* min_x, std::uint32_t n, std::vector<std::uint32_t>& order,
                 std::vector<std::uint64_t>& scratch) {
  order_by_value(min_x, n, order, scratch);
}

}  // namespace hbp
