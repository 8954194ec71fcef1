// SPDX-License-Identifier: MIT
// The two-level hierarchy: per-cell SAH BVHs over the k-d partition's cells,
// their maintenance (refit, removal/insertion, rebuild on degradation) and the
// top-level k-d tree rebuilt from the cells' regions.
#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <cstring>
#include <numeric>
#include <random>
#include <set>
#include <vector>

#include "hbp/scenario.hpp"
#include "hbp/two_level_hierarchy.hpp"
#include "hierarchy/cell_bvh.hpp"
#include "scenario_hierarchy.hpp"

namespace hbp {
namespace {

// Checks one BVH against the entries it was built or edited for: pre-order
// layout, one leaf per entry, leaves' boxes equal to the entries', internal
// boxes equal to the union of their children (refit is exact).
void expect_valid_bvh(std::span<const BvhNode> nodes, std::span<const CellEntry> entries, const char* where) {
  SCOPED_TRACE(where);
  if (entries.empty()) {
    EXPECT_TRUE(nodes.empty());
    return;
  }
  ASSERT_EQ(nodes.size(), 2 * entries.size() - 1);
  std::vector<int> seen(entries.size(), 0);
  // Walk from the root: every node reached once, subtrees contiguous.
  std::vector<std::pair<std::uint32_t, std::uint32_t>> stack{{0u, static_cast<std::uint32_t>(nodes.size())}};
  std::size_t visited = 0;
  while (!stack.empty()) {
    const auto [i, end] = stack.back();
    stack.pop_back();
    ++visited;
    const BvhNode& n = nodes[i];
    if (n.leaf()) {
      ASSERT_EQ(end, i + 1);
      ASSERT_LT(n.right, entries.size());
      const CellEntry& e = entries[n.right];
      EXPECT_EQ(n.object, e.id);
      ++seen[n.right];
      for (int k = 0; k < 3; ++k) {
        EXPECT_EQ(n.min[k], e.min[k]);
        EXPECT_EQ(n.max[k], e.max[k]);
      }
      continue;
    }
    ASSERT_GT(n.right, i + 1);
    ASSERT_LT(n.right, end);
    const BvhNode& l = nodes[i + 1];
    const BvhNode& r = nodes[n.right];
    for (int k = 0; k < 3; ++k) {
      EXPECT_EQ(n.min[k], std::min(l.min[k], r.min[k]));
      EXPECT_EQ(n.max[k], std::max(l.max[k], r.max[k]));
    }
    stack.push_back({i + 1, n.right});
    stack.push_back({n.right, end});
  }
  EXPECT_EQ(visited, nodes.size());
  for (std::size_t e = 0; e < seen.size(); ++e) EXPECT_EQ(seen[e], 1) << "entry " << e;
}

// Which top-level leaf a point falls in (half-open regions).
std::uint32_t locate(std::span<const KdNode> kd, const float p[3]) {
  std::uint32_t node = 0;
  while (kd[node].axis >= 0) node = kd[node].child + (p[kd[node].axis] < kd[node].split ? 0 : 1);
  return kd[node].cell;
}

void expect_valid_hierarchy(const TwoLevelHierarchy& h, const BoxArray& boxes) {
  const KdPartition& p = h.partition();
  std::uint64_t leaves = 0;
  for (std::uint32_t c = 0; c < h.cell_count(); ++c) {
    expect_valid_bvh(h.cell_bvh(c), p.cell(c), "cell");
    leaves += p.cell(c).size();
  }
  EXPECT_EQ(leaves, p.stats().entries);
  // Top level: each cell is one leaf, and a point inside a cell's region
  // (a corner nudged inwards) is routed to that cell.
  std::vector<int> leaf_count(h.cell_count(), 0);
  for (const KdNode& n : h.kd_nodes())
    if (n.axis < 0) ++leaf_count[n.cell];
  for (std::uint32_t c = 0; c < h.cell_count(); ++c) {
    EXPECT_EQ(leaf_count[c], 1) << "cell " << c;
    const CellRegion& r = p.region(c);
    float q[3];
    for (int k = 0; k < 3; ++k) q[k] = std::isfinite(r.lo[k]) ? r.lo[k] : (std::isfinite(r.hi[k]) ? r.hi[k] - 1 : 0);
    EXPECT_EQ(locate(h.kd_nodes(), q), c);
  }
  // Scene bounds are the union of the boxes.
  for (int k = 0; k < 3; ++k) {
    EXPECT_EQ(h.bounds().min[k], *std::min_element(boxes.min(k), boxes.min(k) + boxes.size()));
    EXPECT_EQ(h.bounds().max[k], *std::max_element(boxes.max(k), boxes.max(k) + boxes.size()));
  }
}

std::vector<CellEntry> random_entries(std::mt19937& rng, std::uint32_t count, std::uint32_t id_stride) {
  std::uniform_real_distribution<float> pos(0, 1000), size(1, 60);
  std::vector<CellEntry> out(count);
  for (std::uint32_t i = 0; i < count; ++i) {
    for (int k = 0; k < 3; ++k) {
      out[i].min[k] = pos(rng);
      out[i].max[k] = out[i].min[k] + size(rng);
    }
    out[i].id = i * id_stride;
    out[i].build_tag = 0;
  }
  return out;
}

TEST(CellBvh, BuildGivesOneLeafPerEntryAndExactBoxes) {
  std::mt19937 rng(1);
  bvh::Scratch scratch;
  for (std::uint32_t count : {1u, 2u, 3u, 17u, 1024u, 20000u}) {
    const auto entries = random_entries(rng, count, 1);
    std::vector<BvhNode> nodes;
    bvh::build(entries, nodes, scratch);
    expect_valid_bvh(nodes, entries, "build");
    // A SAH tree of uniformly spread boxes is far cheaper than the worst
    // (every internal node as large as the root).
    if (count >= 17) {
      EXPECT_LT(bvh::sah_cost(nodes), 0.5f * static_cast<float>(count - 1));
    }
  }
}

TEST(CellBvh, IdenticalBoxesStillSplitDownToOneObject) {
  std::vector<CellEntry> entries(300);
  for (std::uint32_t i = 0; i < entries.size(); ++i) entries[i] = CellEntry{{1, 2, 3}, {4, 5, 6}, i, 0};
  bvh::Scratch scratch;
  std::vector<BvhNode> nodes;
  bvh::build(entries, nodes, scratch);
  expect_valid_bvh(nodes, entries, "identical");
}

TEST(CellBvh, RefitFollowsMotionAndReportsDegradation) {
  std::mt19937 rng(2);
  auto entries = random_entries(rng, 512, 1);
  bvh::Scratch scratch;
  std::vector<BvhNode> nodes;
  bvh::build(entries, nodes, scratch);
  const float built = bvh::sah_cost(nodes);
  EXPECT_FLOAT_EQ(bvh::refit(entries, nodes), built);
  // Shuffle the boxes among the objects: the tree's grouping is now random.
  std::vector<CellEntry> shuffled = entries;
  std::shuffle(shuffled.begin(), shuffled.end(), rng);
  for (std::uint32_t i = 0; i < shuffled.size(); ++i) shuffled[i].id = entries[i].id;
  const float degraded = bvh::refit(shuffled, nodes);
  expect_valid_bvh(nodes, shuffled, "refit");
  EXPECT_GT(degraded, 3 * built);
}

TEST(CellBvh, EditRemovesAndInsertsObjects) {
  std::mt19937 rng(3);
  auto before = random_entries(rng, 600, 2);  // even ids
  bvh::Scratch scratch;
  std::vector<BvhNode> nodes;
  bvh::build(before, nodes, scratch);
  std::vector<std::uint32_t> old_ids;
  for (const CellEntry& e : before) old_ids.push_back(e.id);

  // Drop every 7th object, add 40 odd ids, move everyone a little.
  std::vector<CellEntry> after;
  for (std::uint32_t i = 0; i < before.size(); ++i)
    if (i % 7 != 3) after.push_back(before[i]);
  auto extra = random_entries(rng, 40, 2);
  for (std::uint32_t i = 0; i < extra.size(); ++i) {
    extra[i].id = 2 * (i * 13) + 1;
    after.push_back(extra[i]);
  }
  std::sort(after.begin(), after.end(), [](const CellEntry& a, const CellEntry& b) { return a.id < b.id; });
  for (CellEntry& e : after) {
    e.min[0] += 0.5f;
    e.max[0] += 0.5f;
  }
  const std::uint32_t changes = 600 / 7 + 1 + 40;
  EXPECT_FALSE(bvh::edit(after, old_ids, nodes, changes - 10, scratch));  // too many: caller rebuilds
  expect_valid_bvh(nodes, before, "untouched");
  ASSERT_TRUE(bvh::edit(after, old_ids, nodes, changes, scratch));
  bvh::refit(after, nodes);
  expect_valid_bvh(nodes, after, "edited");
}

TEST(TwoLevelHierarchy, InvariantsHoldOverFramesOfThePaperScene) {
  ScenarioParams sp;
  sp.n = 6000;
  test::ScenarioHierarchy w(sp, {.cell_limit = 256});
  std::uint64_t refitted = 0, edited = 0, rebuilt = 0;
  for (std::uint32_t frame = 0; frame < 40; ++frame) {
    w.frame(frame);
    const HierarchyStats& s = w.h.stats();
    EXPECT_EQ(s.cells, w.h.cell_count());
    EXPECT_EQ(s.refitted + s.edited + s.rebuilt, s.cells);
    EXPECT_EQ(s.bvh_nodes, 2 * w.h.partition().stats().entries - s.cells);  // no empty cells here
    if (frame == 0) {
      EXPECT_EQ(s.rebuilt, s.cells);
      EXPECT_TRUE(s.top_rebuilt);
    } else {
      refitted += s.refitted;
      edited += s.edited;
      rebuilt += s.rebuilt;
    }
    if (frame % 13 == 0 || frame == 39) expect_valid_hierarchy(w.h, w.boxes);
  }
  EXPECT_GT(w.h.cell_count(), 20u);
  // Objects move ~0.4 m per frame in cells ~200 m wide: most cells keep their
  // tree (refit, or a few objects removed/inserted); few are rebuilt.
  EXPECT_GT(refitted + edited, 5 * rebuilt);
  EXPECT_GT(edited, 0u);
  EXPECT_GT(refitted, 0u);
}

TEST(TwoLevelHierarchy, RebuildRatioControlsDegradationRebuilds) {
  ScenarioParams sp;
  sp.n = 3000;
  sp.linear_speed = 250;  // fast: trees degrade quickly
  for (float ratio : {1.0f, 1e6f}) {
    test::ScenarioHierarchy w(sp, {.cell_limit = 512, .rebuild_ratio = ratio});
    std::uint64_t degraded = 0, kept = 0;
    for (std::uint32_t frame = 0; frame < 15; ++frame) {
      w.frame(frame);
      if (frame > 0) {
        degraded += w.h.stats().degraded;
        kept += w.h.stats().refitted + w.h.stats().edited;
      }
    }
    expect_valid_hierarchy(w.h, w.boxes);
    if (ratio == 1.0f) {
      EXPECT_GT(degraded, 0u);
    } else {
      EXPECT_EQ(degraded, 0u);
      EXPECT_GT(kept, 0u);
    }
  }
}

TEST(TwoLevelHierarchy, SingleCellAndEmptyScenes) {
  TwoLevelHierarchy h;
  BoxArray boxes;
  boxes.push_back(Aabb{{0, 0, 0}, {1, 1, 1}});
  boxes.push_back(Aabb{{2, 0, 0}, {3, 1, 1}});
  h.update(boxes);
  ASSERT_EQ(h.cell_count(), 1u);
  ASSERT_EQ(h.kd_nodes().size(), 1u);
  EXPECT_EQ(h.kd_nodes()[0].axis, -1);
  expect_valid_hierarchy(h, boxes);
  EXPECT_EQ(h.cell_bvh(0).size(), 3u);
}

}  // namespace
}  // namespace hbp
