// SPDX-License-Identifier: MIT
#pragma once
// The reference for pair events: with both lists sorted, a frame's created
// pairs are minus(now, before) and its removed pairs minus(before, now).
#include <algorithm>
#include <iterator>
#include <vector>

#include "hbp/pair.hpp"

namespace hbp::test {

// The pairs of sorted `a` that sorted `b` lacks, in order.
inline std::vector<Pair> minus(const std::vector<Pair>& a, const std::vector<Pair>& b) {
  std::vector<Pair> out;
  std::set_difference(a.begin(), a.end(), b.begin(), b.end(), std::back_inserter(out));
  return out;
}

}  // namespace hbp::test
