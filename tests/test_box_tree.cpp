// SPDX-License-Identifier: MIT
// BoxTree (the query tree of BroadPhase: 8-bit quantised nodes over exact
// four-box leaves) against a scan of every box: box queries with the closed
// overlap test, rays with RaySegment::hits (same hits, same entry t), on
// scenes built to stress the outward rounding of the quantised bounds:
// touching faces on an integer lattice, points and flat boxes, identical
// boxes, huge and tiny coordinates, every size from an empty tree through a
// lone leaf to thousands of boxes; and again after refits.
#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <limits>
#include <stdexcept>
#include <string>
#include <utility>
#include <vector>

#include "hbp/aabb.hpp"
#include "hbp/box_array.hpp"
#include "pipeline/box_tree.hpp"
#include "pipeline/ray_segment.hpp"
#include "support/random.hpp"

namespace {

using hbp::Aabb;
using hbp::BoxArray;
using hbp::detail::BoxTree;
using hbp::detail::RaySegment;

constexpr float kInf = std::numeric_limits<float>::infinity();

std::vector<std::uint32_t> ids_for(std::size_t n) {
  std::vector<std::uint32_t> ids(n);
  for (std::size_t i = 0; i < n; ++i) ids[i] = static_cast<std::uint32_t>(i * 7 + 3);
  return ids;
}

// Asserts the tree's box answer equals the scan's, with exact items.
void check_box(const BoxTree& tree, const BoxArray& boxes, const std::vector<std::uint32_t>& ids, const Aabb& q) {
  std::vector<std::uint32_t> got, want;
  tree.for_each_overlap(q, [&](std::uint32_t index, const BoxTree::Item& it) {
    got.push_back(index);
    ASSERT_EQ(it.index, index);
    ASSERT_EQ(it.id, ids[index]);
    const Aabb b = boxes.get(index);
    for (int k = 0; k < 3; ++k) {
      ASSERT_EQ(it.min[k], b.min[k]);
      ASSERT_EQ(it.max[k], b.max[k]);
    }
  });
  for (std::uint32_t i = 0; i < boxes.size(); ++i)
    if (hbp::overlaps(boxes.get(i), q)) want.push_back(i);
  std::sort(got.begin(), got.end());
  ASSERT_EQ(got, want) << "query [" << q.min[0] << " " << q.min[1] << " " << q.min[2] << ", " << q.max[0] << " "
                       << q.max[1] << " " << q.max[2] << "]";
}

// Asserts the tree's ray hits and entry t equal RaySegment::hits over a scan.
void check_ray(const BoxTree& tree, const BoxArray& boxes, const float o[3], const float d[3], float max_t) {
  const RaySegment ray(o, d, max_t);
  std::vector<std::pair<std::uint32_t, float>> got, want;
  tree.for_each_ray_hit(ray, [&](const BoxTree::Item& it, float t) { got.emplace_back(it.index, t); });
  for (std::uint32_t i = 0; i < boxes.size(); ++i) {
    const Aabb b = boxes.get(i);
    float t;
    if (ray.hits(b.min, b.max, t)) want.emplace_back(i, t);
  }
  std::sort(got.begin(), got.end());
  // The walk without AVX2 (four-lane node test) gives the same answer.
  std::vector<std::pair<std::uint32_t, float>> portable;
  tree.for_each_ray_hit_portable(ray, [&](const BoxTree::Item& it, float t) { portable.emplace_back(it.index, t); });
  std::sort(portable.begin(), portable.end());
  ASSERT_EQ(portable, want) << "portable walk";
  ASSERT_EQ(got, want) << "ray o (" << o[0] << " " << o[1] << " " << o[2] << ") d (" << d[0] << " " << d[1] << " "
                       << d[2] << ") max_t " << max_t;
}

// Boxes on an integer lattice (touching faces, shared corners), some points
// and flat boxes, some exact duplicates of earlier boxes.
BoxArray lattice_boxes(hbp::Random& rng, std::size_t n, float cell, float offset) {
  BoxArray boxes(n);
  for (std::size_t i = 0; i < n; ++i) {
    Aabb b;
    if (i > 0 && rng.below(10) == 0) {
      b = boxes.get(rng.below(static_cast<std::uint32_t>(i)));
    } else {
      for (int k = 0; k < 3; ++k) {
        const auto lo = static_cast<float>(rng.below(40));
        const std::uint32_t kind = rng.below(6);
        const float size = kind == 0 ? 0.0f : kind == 1 ? 0.5f : static_cast<float>(1 + rng.below(3));
        b.min[k] = offset + lo * cell;
        b.max[k] = offset + (lo + size) * cell;
      }
    }
    boxes.set(i, b);
  }
  return boxes;
}

void check_scene(const BoxTree& tree, const BoxArray& boxes, const std::vector<std::uint32_t>& ids, hbp::Random& rng,
                 float cell, float offset, int queries) {
  const auto at = [&](float lattice) { return offset + lattice * cell; };
  for (int i = 0; i < queries; ++i) {
    // Query boxes on the lattice (touching faces), points, and each box itself.
    Aabb q;
    for (int k = 0; k < 3; ++k) {
      const auto lo = static_cast<float>(rng.below(44)) - 2;
      q.min[k] = at(lo);
      q.max[k] = at(lo + static_cast<float>(rng.below(4)));
    }
    check_box(tree, boxes, ids, q);
    if (boxes.size() > 0) check_box(tree, boxes, ids, boxes.get(rng.below(static_cast<std::uint32_t>(boxes.size()))));
    // Rays: along axes and diagonals with zero components (grazing faces
    // from lattice origins), random directions, max_t on a face (integer
    // lattice, unit steps: exact t), 0 and infinity.
    float o[3], d[3];
    for (int k = 0; k < 3; ++k) {
      o[k] = at(static_cast<float>(rng.below(44)) - 2);
      const std::uint32_t kind = rng.below(4);
      d[k] = kind == 0 ? 0.0f : kind == 1 ? cell : kind == 2 ? -cell : static_cast<float>(rng.uniform(-1, 1)) * cell;
    }
    const std::uint32_t t_kind = rng.below(4);
    const float max_t = t_kind == 0 ? 0.0f : t_kind == 1 ? kInf : static_cast<float>(rng.below(30));
    check_ray(tree, boxes, o, d, max_t);
  }
}

TEST(BoxTree, EverySizeMatchesScanOnLattice) {
  hbp::Random rng(11);
  for (std::size_t n : {0, 1, 2, 3, 4, 5, 8, 9, 17, 64, 300, 2000}) {
    SCOPED_TRACE(n);
    const BoxArray boxes = lattice_boxes(rng, n, 1.0f, 0.0f);
    const auto ids = ids_for(n);
    BoxTree tree;
    tree.build(boxes, ids);
    EXPECT_EQ(tree.empty(), n == 0);
    check_scene(tree, boxes, ids, rng, 1.0f, 0.0f, n < 100 ? 60 : 150);
  }
}

// Lattices whose float spacing stresses the rounding: far from the origin
// (a cell a few ulps wide), tiny (subnormal steps) and huge (ranges whose
// width overflows float).
TEST(BoxTree, ExtremeCoordinatesMatchScan) {
  hbp::Random rng(12);
  const std::pair<float, float> scenes[] = {
      {1.0f, 1.0e7f},       // cells of one unit at 1e7: a few ulps
      {1.0e-40f, 0.0f},     // subnormal lattice
      {3.0e-39f, -1.0e-38f},
      {1.0e36f, -2.0e37f},  // 40 cells of 1e36 across the origin
      {8.0e36f, -1.6e38f},  // the lattice spans most of float's range
  };
  for (const auto& [cell, offset] : scenes) {
    SCOPED_TRACE(cell);
    const BoxArray boxes = lattice_boxes(rng, 700, cell, offset);
    const auto ids = ids_for(boxes.size());
    BoxTree tree;
    tree.build(boxes, ids);
    check_scene(tree, boxes, ids, rng, cell, offset, 120);
  }
  // Boxes from -FLT_MAX to FLT_MAX with points at both ends.
  BoxArray wide(6);
  const float big = std::numeric_limits<float>::max();
  wide.set(0, Aabb{{-big, -big, -big}, {big, big, big}});
  wide.set(1, Aabb{{-big, -big, -big}, {-big, -big, -big}});
  wide.set(2, Aabb{{big, big, big}, {big, big, big}});
  wide.set(3, Aabb{{0, 0, 0}, {0, 0, 0}});
  wide.set(4, Aabb{{-big, 0, 1}, {-big / 2, 1, 2}});
  wide.set(5, Aabb{{big / 2, -1, -big}, {big, 0, big}});
  const auto ids = ids_for(wide.size());
  BoxTree tree;
  tree.build(wide, ids);
  for (std::size_t i = 0; i < wide.size(); ++i) check_box(tree, wide, ids, wide.get(i));
  check_box(tree, wide, ids, Aabb{{big, big, big}, {big, big, big}});
  const float o[3] = {0, 0, 0}, d[3] = {1, 0, 0}, dn[3] = {-1, 0, 0};
  check_ray(tree, wide, o, d, kInf);
  check_ray(tree, wide, o, dn, kInf);
}

// Refit keeps the membership and takes new boxes: after every round of
// moves (small nudges and teleports) the answers match the scan.
TEST(BoxTree, RefitMatchesScan) {
  hbp::Random rng(13);
  BoxArray boxes = lattice_boxes(rng, 1500, 1.0f, 0.0f);
  const auto ids = ids_for(boxes.size());
  BoxTree tree;
  tree.build(boxes, ids);
  for (int round = 0; round < 4; ++round) {
    for (std::size_t i = 0; i < boxes.size(); ++i) {
      if (rng.below(3) != 0) continue;
      Aabb b = boxes.get(i);
      const bool teleport = rng.below(10) == 0;
      for (int k = 0; k < 3; ++k) {
        const float shift = teleport ? static_cast<float>(rng.below(40)) - b.min[k] : static_cast<float>(rng.below(3)) - 1;
        b.min[k] += shift;
        b.max[k] += shift;
      }
      boxes.set(i, b);
    }
    tree.refit(boxes);
    check_scene(tree, boxes, ids, rng, 1.0f, 0.0f, 100);
  }
}

// Refits of a tree whose boxes span the whole float range on one axis: a
// node's top code decodes past FLT_MAX, and the refit must not let that
// infinity into a parent's step (0 * inf = NaN would hide every box). Many
// boxes, so the tree has nodes above nodes; refitted with unchanged boxes,
// then with every box moved and some widened to [-FLT_MAX, FLT_MAX].
TEST(BoxTree, RefitOfBoxesSpanningTheFloatRangeMatchesScan) {
  hbp::Random rng(21);
  const float big = std::numeric_limits<float>::max();
  for (int axis = 0; axis < 3; ++axis) {
    SCOPED_TRACE(axis);
    BoxArray boxes = lattice_boxes(rng, 600, 1.0f, 0.0f);
    for (std::size_t i = 0; i < boxes.size(); ++i) {
      Aabb b = boxes.get(i);
      if (i % 3 == 0) {
        b.min[axis] = -big;
        b.max[axis] = big;
      } else if (i % 3 == 1) {
        b.max[axis] = big;
      }
      boxes.set(i, b);
    }
    const auto ids = ids_for(boxes.size());
    BoxTree tree;
    tree.build(boxes, ids);
    ASSERT_GE(tree.depth(), 3u) << "the case needs nodes under nodes";
    for (int round = 0; round < 4; ++round) {
      if (round >= 2) {
        for (std::size_t i = 0; i < boxes.size(); ++i) {
          Aabb b = boxes.get(i);
          const int k = (axis + 1) % 3;
          b.min[k] += 1;
          b.max[k] += 1;
          if (rng.below(5) == 0) {
            b.min[axis] = -big;
            b.max[axis] = big;
          }
          boxes.set(i, b);
        }
      }
      tree.refit(boxes);
      for (std::size_t i = 0; i < boxes.size(); i += 37) check_box(tree, boxes, ids, boxes.get(i));
      check_box(tree, boxes, ids, Aabb{{-big, -big, -big}, {big, big, big}});
      check_box(tree, boxes, ids, Aabb{{2, 2, 2}, {3, 3, 3}});
      check_scene(tree, boxes, ids, rng, 1.0f, 0.0f, 40);
    }
  }
}

// Boxes of exponentially growing size and spacing: the SAH splits peel a
// few boxes off per level, a chain of nodes each with leaves beside it (the
// leaf ring overflows again and again during one walk).
TEST(BoxTree, DeepTreeMatchesScan) {
  hbp::Random rng(14);
  const std::size_t n = 1200;
  BoxArray boxes(n);
  for (std::size_t i = 0; i < n; ++i) {
    const auto x = static_cast<float>(std::pow(1.07, static_cast<double>(i)));
    boxes.set(i, Aabb{{x, 0, 0}, {x * 1.05f, 1, 1}});
  }
  const auto ids = ids_for(n);
  BoxTree tree;
  tree.build(boxes, ids);
  EXPECT_GT(tree.depth(), 30u);
  for (std::size_t i = 0; i < n; i += 7) check_box(tree, boxes, ids, boxes.get(i));
  check_box(tree, boxes, ids, Aabb{{0, 0, 0}, {kInf, 1, 1}});
  const float o[3] = {0, 0.5f, 0.5f}, d[3] = {1, 0, 0};
  check_ray(tree, boxes, o, d, kInf);
}

// The quantisation needs finite ordered boxes: others are refused by name.
TEST(BoxTree, RejectsNonFiniteAndInvertedBoxes) {
  const float nan = std::numeric_limits<float>::quiet_NaN();
  const Aabb bad[] = {{{0, 0, nan}, {1, 1, 1}}, {{0, 0, 0}, {kInf, 1, 1}}, {{0, -kInf, 0}, {1, 1, 1}}, {{0, 2, 0}, {1, 1, 1}}};
  for (const Aabb& b : bad) {
    BoxArray boxes(5);
    for (std::size_t i = 0; i < 5; ++i) boxes.set(i, Aabb{{0, 0, 0}, {1, 1, 1}});
    boxes.set(3, b);
    BoxTree tree;
    try {
      tree.build(boxes, ids_for(5));
      FAIL() << "accepted a bad box";
    } catch (const std::invalid_argument& e) {
      EXPECT_NE(std::string(e.what()).find("box 3"), std::string::npos) << e.what();
    }
  }
}

}  // namespace
