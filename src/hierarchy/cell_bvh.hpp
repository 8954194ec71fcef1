// SPDX-License-Identifier: MIT
#pragma once
// The BVH inside one cell of the two-level hierarchy (and, for comparison, over
// a whole scene): binned surface-area-heuristic build down to one object per
// leaf, refit, and removal/insertion of a few objects. Nodes are BvhNode in
// depth-first pre-order, so a subtree is a contiguous range and a reverse
// sweep refits children before parents.
#include <cstdint>
#include <span>
#include <vector>

#include "hbp/box_array.hpp"
#include "hbp/kd_partition.hpp"
#include "hbp/two_level_hierarchy.hpp"

namespace hbp::bvh {

// Reusable buffers (one per thread).
struct Scratch {
  std::vector<CellEntry> items;
  std::vector<std::uint32_t> remap, added, leaf_of, left, right, parent, stack;
  std::vector<BvhNode> work;
};

// Builds over entries (leaf: right = entry index, object = entry id).
// Large inputs build their subtrees in parallel.
void build(std::span<const CellEntry> entries, std::vector<BvhNode>& nodes, Scratch& scratch);
// Builds over every box of `boxes` (leaf: right = object = box index).
void build(const BoxArray& boxes, std::vector<BvhNode>& nodes, Scratch& scratch);

// Refits to the current boxes and returns the SAH cost: the sum of the
// internal nodes' surface areas over the root's (0 for fewer than 2 leaves).
float refit(std::span<const CellEntry> entries, std::span<BvhNode> nodes);
float refit(const BoxArray& boxes, std::span<BvhNode> nodes);  // parallel when large
float sah_cost(std::span<const BvhNode> nodes);

// Membership changed from `old_ids` (old entry index -> id) to `entries`
// (any order; the partition delivers min-x order): removes the leaves of departed objects, renumbers
// the survivors' entry indices, inserts the newcomers where they enlarge the
// tree least, and leaves `nodes` in pre-order (boxes not yet refitted).
// Returns false, leaving `nodes` untouched, when more than
// max_changes objects changed (the caller rebuilds instead).
bool edit(std::span<const CellEntry> entries, std::span<const std::uint32_t> old_ids, std::vector<BvhNode>& nodes,
          std::uint32_t max_changes, Scratch& scratch);

}  // namespace hbp::bvh
