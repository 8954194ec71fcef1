// SPDX-License-Identifier: MIT
#pragma once
// The two-level hierarchy shared by collision detection and the ray tracer
// (paper, section 3.2): a k-d tree subdivided until each leaf ("cell") holds at
// most the cell limit, and inside each cell a BVH built by the surface-area
// heuristic down to one object per leaf.
//
//   hbp::TwoLevelHierarchy h;               // cell limit 1024, like "sw"
//   h.update(boxes);                        // each frame
//   h.partition().cell(c)                   // what the cell engines read
//   h.cell_bvh(c), h.kd_nodes()             // what the ray tracer traverses
//
// Per frame: the partition is maintained (routing, splits, merges); a cell
// whose region and objects are unchanged has its BVH refitted; a cell that
// gained or lost a few objects has them removed/inserted (then refitted); a
// new cell, a cell with many changes, or a BVH whose SAH cost degraded past
// `rebuild_ratio` times its cost when built, is rebuilt (binned SAH).
#include <cstddef>
#include <cstdint>
#include <memory>
#include <span>
#include <vector>

#include "hbp/aabb.hpp"
#include "hbp/box_array.hpp"
#include "hbp/kd_partition.hpp"

namespace hbp {

// A BVH node, 32 bytes, stored in depth-first pre-order: an internal node's
// left child is the next node, its right child is `right`. A leaf holds one
// object: `object` is its id, `right` its entry index within the cell.
struct BvhNode {
  float min[3];
  float max[3];
  std::uint32_t right;
  std::uint32_t object;

  static constexpr std::uint32_t kInternal = 0xFFFFFFFFu;
  bool leaf() const { return object != kInternal; }
};
static_assert(sizeof(BvhNode) == 32 && offsetof(BvhNode, right) == 24 && offsetof(BvhNode, object) == 28,
              "BvhNode is 32 bytes, eight 4-byte words");

// A node of the top level (the k-d tree over the cells): axis -1 is a leaf
// holding `cell`; otherwise children are `child` (below `split`) and
// `child + 1` (at or above it: half-open regions, like the partition).
struct KdNode {
  float split;
  std::int32_t axis;
  std::uint32_t child;
  std::uint32_t cell;
};

struct HierarchyOptions {
  std::uint32_t cell_limit = 1024;  // the software engine's default
  float x_split_weight = 0.5f;      // idem (sweep along x)
  float rebuild_ratio = 1.4f;       // rebuild a cell's BVH past this SAH growth
  float max_edit_fraction = 0.25f;  // more changed objects than this: rebuild
};

struct HierarchyStats {
  std::uint32_t cells = 0;
  std::uint32_t refitted = 0;  // cells refitted only
  std::uint32_t edited = 0;    // cells with objects removed/inserted, then refitted
  std::uint32_t rebuilt = 0;   // cells rebuilt (new, many changes or degraded)
  std::uint32_t degraded = 0;  // of the rebuilt: because of the SAH cost
  std::uint64_t bvh_nodes = 0;
  bool top_rebuilt = false;  // the top level followed a partition change
  // Wall times of this frame's maintenance.
  double partition_ms = 0, bvh_ms = 0, top_ms = 0, total_ms = 0;
};

class TwoLevelHierarchy {
 public:
  explicit TwoLevelHierarchy(const HierarchyOptions& options = {});
  ~TwoLevelHierarchy();
  TwoLevelHierarchy(TwoLevelHierarchy&&) noexcept;
  TwoLevelHierarchy& operator=(TwoLevelHierarchy&&) noexcept;

  // Maintains both levels for this frame's boxes (object i of this frame is
  // object i of the previous one).
  void update(const BoxArray& boxes);

  const KdPartition& partition() const { return partition_; }
  std::uint32_t cell_count() const { return partition_.cell_count(); }
  // Cell c's BVH (empty for an empty cell), root at index 0.
  std::span<const BvhNode> cell_bvh(std::uint32_t c) const;
  // The top level, root at index 0 (a single leaf when there is one cell).
  std::span<const KdNode> kd_nodes() const { return kd_nodes_; }
  // Union of this frame's boxes.
  const Aabb& bounds() const { return bounds_; }
  const HierarchyStats& stats() const { return stats_; }
  const HierarchyOptions& options() const { return options_; }
  // SAH cost of cell c's BVH (sum of internal node areas over the root's).
  float cell_sah_cost(std::uint32_t c) const;

 private:
  struct CellTrees;
  void update_top_level();

  HierarchyOptions options_;
  KdPartition partition_;
  std::unique_ptr<CellTrees> trees_;
  std::vector<KdNode> kd_nodes_;
  std::vector<CellRegion> top_regions_;  // the regions the top level was built for
  Aabb bounds_{};
  HierarchyStats stats_;
};

}  // namespace hbp
