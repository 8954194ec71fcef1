// SPDX-License-Identifier: MIT
#pragma once
// The oracle: all-pairs over the closed-interval test, deliberately simple.
// Every engine, model and baseline is checked against it; the "brute" cell
// engine, the "brute" baseline and the area-efficient hardware order (anchor i
// ascending, partner j ascending) are this one loop.
#include <cstdint>
#include <vector>

#include "hbp/box_array.hpp"
#include "hbp/pair.hpp"

namespace hbp {

// The closed-interval test of overlaps(Aabb, Aabb) read straight from the SoA
// lanes: six comparisons combined with & rather than && so the compiler emits
// branch-free code; only the (rare) hit branches.
struct BoxLanes {
  const float* lo[3];
  const float* hi[3];
  explicit BoxLanes(const BoxArray& b) : lo{b.min(0), b.min(1), b.min(2)}, hi{b.max(0), b.max(1), b.max(2)} {}
  bool overlap(std::uint32_t i, std::uint32_t j) const {
    return (hi[0][i] >= lo[0][j]) & (lo[0][i] <= hi[0][j]) & (hi[1][i] >= lo[1][j]) & (lo[1][i] <= hi[1][j]) &
           (hi[2][i] >= lo[2][j]) & (lo[2][i] <= hi[2][j]);
  }
};

// Sorted, canonical pairs of all overlapping boxes.
std::vector<Pair> brute_force_pairs(const BoxArray& boxes);

// Appends the overlapping pairs of `boxes` to `out` in row order: anchor i
// ascending, partner j > i ascending (sorted and canonical within the call).
// Stops with CapacityExceeded once the call has appended more than
// `max_pairs` pairs; checked once per anchor row, so at most one row (n pairs)
// beyond the limit is ever held and the inner loop stays branch-free.
void append_brute_force_pairs(const BoxArray& boxes, std::vector<Pair>& out,
                              std::uint64_t max_pairs = ~std::uint64_t{0});

}  // namespace hbp
