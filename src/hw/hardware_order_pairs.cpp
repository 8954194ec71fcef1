// SPDX-License-Identifier: MIT
#include "hbp/hw/hardware_order_pairs.hpp"

#include <algorithm>

#include "hbp/brute_force.hpp"
#include "hbp/hw/pair_limit_check.hpp"

namespace hbp::hw {

// The pair limit is checked once per anchor row (area-efficient) or step
// (many-object), so the inner loops stay branch-free: a call stops at most
// one row (n pairs) or one step (m pairs) past the limit.
void area_efficient_order_pairs(const BoxArray& boxes, std::vector<Pair>& out, std::uint64_t max_pairs) {
  // The hardware's anchor/partner order is the oracle's row order.
  append_brute_force_pairs(boxes, out, max_pairs);
}

void many_object_order_pairs(const BoxArray& boxes, std::uint32_t m, std::vector<Pair>& out,
                             std::uint64_t max_pairs) {
  const BoxLanes lanes(boxes);
  const auto n = static_cast<std::uint32_t>(boxes.size());
  const std::size_t base = out.size();
  for (std::uint32_t row_first = 0; row_first + 1 < n; row_first += m) {
    const std::uint32_t steps = n - row_first - 1;
    for (std::uint32_t b = 1; b <= steps; ++b) {
      check_pair_limit(out.size() - base, max_pairs, n);
      // Comparator k pairs object row_first+k with row_first+k+b; slots whose
      // partner is >= n are the ones the hardware discards.
      const std::uint32_t last_k = std::min<std::uint32_t>(m, n - row_first - b);
      for (std::uint32_t k = 0; k < last_k; ++k) {
        const std::uint32_t x = row_first + k;
        if (lanes.overlap(x, x + b)) out.push_back({x, x + b});
      }
    }
  }
  check_pair_limit(out.size() - base, max_pairs, n);
}

}  // namespace hbp::hw
