// SPDX-License-Identifier: MIT
#include "hbp/brute_force.hpp"

#include <string>

#include "hbp/error.hpp"

namespace hbp {
void append_brute_force_pairs(const BoxArray& boxes, std::vector<Pair>& out, std::uint64_t max_pairs) {
  const BoxLanes lanes(boxes);
  const auto n = static_cast<std::uint32_t>(boxes.size());
  const std::size_t base = out.size();
  for (std::uint32_t i = 0; i + 1 < n; ++i) {
    for (std::uint32_t j = i + 1; j < n; ++j) {
      if (lanes.overlap(i, j)) out.push_back({i, j});
    }
    if (out.size() - base > max_pairs)
      throw CapacityExceeded("cell of " + std::to_string(n) + " boxes has more than " + std::to_string(max_pairs) +
                             " overlapping pairs (max_pairs)");
  }
}

std::vector<Pair> brute_force_pairs(const BoxArray& boxes) {
  std::vector<Pair> pairs;
  append_brute_force_pairs(boxes, pairs);
  return pairs;  // generated in (a, b) order: already sorted and canonical
}

}  // namespace hbp
