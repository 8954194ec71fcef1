// SPDX-License-Identifier: MIT
#include "dedup/owned_pairs.hpp"

#include "dedup/ownership.hpp"

namespace hbp::dedup {

void filter_owned(const BoxArray& cell, const CellRegion& r, std::vector<Pair>& out, std::size_t from) {
  const float *x = cell.min(0), *y = cell.min(1), *z = cell.min(2);
  std::size_t keep = from;
  for (std::size_t p = from; p < out.size(); ++p) {
    const Pair q = out[p];
    if (owns(r, x[q.a], y[q.a], z[q.a], x[q.b], y[q.b], z[q.b])) out[keep++] = q;
  }
  out.resize(keep);
}

}  // namespace hbp::dedup
