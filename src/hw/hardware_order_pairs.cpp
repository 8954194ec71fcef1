#include "hbp/hw/hardware_order_pairs.hpp"

#include <algorithm>

#include "hbp/hw/pair_limit_check.hpp"

namespace hbp::hw {
namespace {

// Six comparisons combined with & rather than && so the compiler emits
// branch-free code; only the (rare) hit branches.
struct BoxLanes {
  const float* lo[3];
  const float* hi[3];
  explicit BoxLanes(const BoxArray& b)
      : lo{b.min(0), b.min(1), b.min(2)}, hi{b.max(0), b.max(1), b.max(2)} {}
  bool overlap(std::uint32_t i, std::uint32_t j) const {
    return (hi[0][i] >= lo[0][j]) & (lo[0][i] <= hi[0][j]) & (hi[1][i] >= lo[1][j]) &
           (lo[1][i] <= hi[1][j]) & (hi[2][i] >= lo[2][j]) & (lo[2][i] <= hi[2][j]);
  }
};

}  // namespace

// The pair limit is checked once per anchor row (area-efficient) or step
// (many-object), so the inner loops stay branch-free: a call stops at most
// one row (n pairs) or one step (m pairs) past the limit.
void area_efficient_order_pairs(const BoxArray& boxes, std::vector<Pair>& out, std::uint64_t max_pairs) {
  const BoxLanes lanes(boxes);
  const auto n = static_cast<std::uint32_t>(boxes.size());
  const std::size_t base = out.size();
  for (std::uint32_t i = 0; i + 1 < n; ++i) {
    for (std::uint32_t j = i + 1; j < n; ++j) {
      if (lanes.overlap(i, j)) out.push_back({i, j});
    }
    check_pair_limit(out.size() - base, max_pairs, n);
  }
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
