// SPDX-License-Identifier: MIT
#pragma once
// The one definition of a percentile and a median for every figure we print
// (hbp run, hbp bench, hbp distributed, the benchmarks): nearest rank.
//
// percentile(v, q) is the smallest value with at least a fraction q of the
// values at or below it: sorted v[ceil(q * n) - 1], rank clamped to [1, n].
// It is always a measured frame, never an interpolation or an average of two.
// median(v) = percentile(v, 0.5): for an even count, the lower of the two
// middle values. An empty list gives 0.
#include <algorithm>
#include <cmath>
#include <cstddef>
#include <utility>
#include <vector>

namespace hbp {

// q in (0, 1]; q <= 0 gives the smallest value.
inline double percentile(std::vector<double> v, double q) {
  if (v.empty()) return 0;
  const auto rank = static_cast<std::size_t>(std::ceil(q * static_cast<double>(v.size())));
  const std::size_t k = std::min(v.size(), std::max<std::size_t>(rank, 1)) - 1;
  std::nth_element(v.begin(), v.begin() + static_cast<std::ptrdiff_t>(k), v.end());
  return v[k];
}

inline double median(std::vector<double> v) { return percentile(std::move(v), 0.5); }

}  // namespace hbp
