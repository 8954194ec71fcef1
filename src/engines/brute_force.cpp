#include "hbp/brute_force.hpp"

namespace hbp {

std::vector<Pair> brute_force_pairs(const BoxArray& boxes) {
  std::vector<Pair> pairs;
  const auto n = static_cast<std::uint32_t>(boxes.size());
  for (std::uint32_t i = 0; i + 1 < n; ++i) {
    const Aabb a = boxes.get(i);
    for (std::uint32_t j = i + 1; j < n; ++j) {
      if (overlaps(a, boxes.get(j))) pairs.push_back({i, j});
    }
  }
  return pairs;  // generated in (a, b) order: already sorted and canonical
}

}  // namespace hbp
