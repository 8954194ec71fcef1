// SPDX-License-Identifier: MIT
// The ownership rule (src/dedup/ownership.hpp) on its own: over a grid of
// half-open cells tiling space, every overlapping pair of random boxes is
// owned by exactly one cell, and that cell's region overlaps both boxes (so
// routing put both there). Coordinates sit on a coarse lattice that includes
// the cell boundaries, so points on planes are common. The per-object form
// (sides / owns_sides) and the after-the-fact filter agree with owns().
#include <gtest/gtest.h>

#include <algorithm>
#include <limits>
#include <random>
#include <vector>

#include "dedup/owned_pairs.hpp"
#include "dedup/ownership.hpp"
#include "hbp/brute_force.hpp"

namespace hbp {
namespace {

constexpr float kInf = std::numeric_limits<float>::infinity();

// Cells of side 4 over [0, 16) per axis, the outer ones open to infinity.
std::vector<CellRegion> grid() {
  const float cuts[] = {-kInf, 4, 8, 12, kInf};
  std::vector<CellRegion> cells;
  for (int i = 0; i < 4; ++i)
    for (int j = 0; j < 4; ++j)
      for (int k = 0; k < 4; ++k)
        cells.push_back({{cuts[i], cuts[j], cuts[k]}, {cuts[i + 1], cuts[j + 1], cuts[k + 1]}});
  return cells;
}

BoxArray lattice_boxes(std::uint32_t n, std::uint64_t seed) {
  std::mt19937_64 rng(seed);
  std::uniform_int_distribution<int> at(-2, 17), size(0, 5);
  BoxArray boxes;
  boxes.resize(n);
  for (std::uint32_t i = 0; i < n; ++i) {
    Aabb b;
    for (int k = 0; k < 3; ++k) {
      b.min[k] = static_cast<float>(at(rng));
      b.max[k] = b.min[k] + static_cast<float>(size(rng));
    }
    boxes.set(i, b);
  }
  return boxes;
}

bool region_overlaps(const CellRegion& r, const Aabb& b) {
  for (int k = 0; k < 3; ++k)
    if (!(b.max[k] >= r.lo[k] && b.min[k] < r.hi[k])) return false;
  return true;
}

TEST(DedupOwnership, EveryOverlappingPairHasExactlyOneOwnerHoldingBoth) {
  const std::vector<CellRegion> cells = grid();
  const BoxArray boxes = lattice_boxes(300, 5);
  const std::vector<Pair> pairs = brute_force_pairs(boxes);
  ASSERT_GT(pairs.size(), 500u);
  for (const Pair& p : pairs) {
    const Aabb a = boxes.get(p.a), b = boxes.get(p.b);
    int owners = 0;
    for (const CellRegion& r : cells) {
      const bool owned = dedup::owns(r, a.min[0], a.min[1], a.min[2], b.min[0], b.min[1], b.min[2]);
      EXPECT_EQ(owned, dedup::owns(r, b.min[0], b.min[1], b.min[2], a.min[0], a.min[1], a.min[2]));
      // The per-object form, as the distributed broad phase uses it.
      const unsigned sa = dedup::sides(r, a.min[0], a.min[1], a.min[2]);
      const unsigned sb = dedup::sides(r, b.min[0], b.min[1], b.min[2]);
      EXPECT_EQ(owned, dedup::owns_sides(sa, sb));
      // The kernels' one-AND form, both ways round.
      EXPECT_EQ(owned, (dedup::owner_code(sb) & dedup::owner_demand(sa)) == 0);
      EXPECT_EQ(owned, (dedup::owner_code(sa) & dedup::owner_demand(sb)) == 0);
      // The sweep's form, with b after a in min-x order.
      const Aabb& first = a.min[0] <= b.min[0] ? a : b;
      const Aabb& second = a.min[0] <= b.min[0] ? b : a;
      EXPECT_EQ(owned, dedup::owns_sorted_x(r, first.min[1], first.min[2], second.min[0], second.min[1], second.min[2]));
      if (owned) {
        ++owners;
        EXPECT_TRUE(region_overlaps(r, a) && region_overlaps(r, b));
      }
    }
    EXPECT_EQ(owners, 1) << "pair (" << p.a << ", " << p.b << ")";
  }
}

TEST(DedupOwnership, FilterOwnedKeepsExactlyTheOwnedPairsInOrder) {
  const std::vector<CellRegion> cells = grid();
  const BoxArray boxes = lattice_boxes(200, 9);
  const std::vector<Pair> pairs = brute_force_pairs(boxes);
  std::size_t kept_total = 0;
  for (const CellRegion& r : cells) {
    std::vector<Pair> out = {Pair{7, 9}};  // pairs before `from` stay
    out.insert(out.end(), pairs.begin(), pairs.end());
    dedup::filter_owned(boxes, r, out, 1);
    std::vector<Pair> expected = {Pair{7, 9}};
    for (const Pair& p : pairs) {
      const Aabb a = boxes.get(p.a), b = boxes.get(p.b);
      if (dedup::owns(r, a.min[0], a.min[1], a.min[2], b.min[0], b.min[1], b.min[2])) expected.push_back(p);
    }
    EXPECT_EQ(out, expected);
    kept_total += out.size() - 1;
  }
  EXPECT_EQ(kept_total, pairs.size());  // each pair kept by exactly one cell
}

}  // namespace
}  // namespace hbp
