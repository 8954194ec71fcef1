// SPDX-License-Identifier: MIT
#pragma once
// The processor's spatial partition: a k-d tree whose leaves ("cells") hold at
// most `cell_limit` objects. An object straddling a split plane is placed in
// every cell it overlaps. The tree is kept across frames: objects are routed
// through the existing planes, over-full leaves are split, sparse sibling
// leaves merged, and the tree is rebuilt when its quality degrades.
//
// Split rule: median of box centres on the axis of largest centre spread
// (the x spread optionally weighted, see the constructor), down to the cell
// limit or, with a cell cost, as far as splitting pays; if
// that split does not shrink both children, the other axes are tried; if none
// does (identical or nested boxes), the leaf stays over-full and the engines
// process it in tiles.
//
// Rebuilds triggered by quality loss (see degraded() in kd_partition.cpp) do
// not stall a frame: the tree is cut into subtrees of at most half a
// frame's share of entries (a sixteenth of the tree's entries, at most
// rebuild_budget()) and each following frame rebuilds a share's worth, in
// parallel, each subtree from its own current members (a subtree
// rebuilt from the objects in its leaves replaces the old one at the frame
// boundary: the planes above it and every other cell stay valid; the planes
// above the subtrees are not re-chosen). Only the
// first frame (and the one after reset()) builds the whole tree at once.
//
// Routing uses half-open cell regions: a box goes left when min < split and
// right when max >= split.
#include <cstddef>
#include <cstdint>
#include <functional>
#include <memory>
#include <span>
#include <vector>

#include "hbp/box_array.hpp"
#include "hbp/cell_region.hpp"

namespace hbp {

struct PartitionStats {
  std::uint32_t cells = 0;
  std::uint64_t entries = 0;  // sum of cell sizes (with duplicates)
  std::uint32_t min_cell = 0, median_cell = 0, max_cell = 0;
  std::uint32_t oversized_cells = 0;  // leaves that could not be split
  std::uint32_t depth = 0;
  double duplication = 1.0;  // entries / objects
  bool rebuilt = false;      // full rebuild this frame
  std::uint32_t rebuilt_subtrees = 0;  // subtrees rebuilt this frame (a spread rebuild)
  std::uint64_t rebuilt_entries = 0;   // their entries
  std::uint32_t splits = 0, merges = 0;
};

// One object's membership of one cell: a copy of its box, so engines never
// chase ids into the frame's arrays. 32 bytes: one write stream per cell when
// the partition scatters entries.
struct CellEntry {
  float min[3];
  float max[3];
  std::uint32_t id;
  // A builder's word per copy, 0 in the cells the partition publishes: the
  // k-d build's fork/owner tag (kd_build.hpp), the cell BVH build's entry
  // index (cell_bvh.cpp). It fills the entry to 32 bytes.
  std::uint32_t build_tag;
};
static_assert(sizeof(CellEntry) == 32 && alignof(CellEntry) == 4, "CellEntry is 32 bytes, eight 4-byte words");
static_assert(offsetof(CellEntry, max) == 12 && offsetof(CellEntry, id) == 24 && offsetof(CellEntry, build_tag) == 28);

// The tree's node, shared by the partition and its builder (kd_build.cpp).
struct KdTreeNode {
  float split = 0;
  std::int32_t axis = -1;    // -1: leaf
  std::uint32_t child = 0;   // left child; right child is child + 1
  std::uint32_t leaf = 0;    // cell index when a leaf
  std::uint32_t size = 0;    // leaves: entries in the cell
  std::uint32_t first = 0;   // leaves: position of the first entry
};

class KdPartition {
 public:
  // x_split_weight scales the x spread when choosing the split axis (< 1
  // favours splitting y and z: cells longer in x, for a sweep along x; the
  // sweep engine asks for 0.5). cell_cost, when given, is the engine's cost of
  // one cell of n objects (the hardware models' cycles): a leaf under the
  // limit is still split while that lowers the summed cost (duplicates
  // included), and sibling leaves are merged when that does not raise it.
  using CellCost = std::function<double(std::uint32_t n)>;
  explicit KdPartition(std::uint32_t cell_limit, float x_split_weight = 1.0f, CellCost cell_cost = {});
  ~KdPartition();
  KdPartition(KdPartition&&) noexcept;
  KdPartition& operator=(KdPartition&&) noexcept;

  // Partitions a frame. Boxes must be valid (no NaN, min <= max). Object i of
  // this frame is assumed to be object i of the previous one (coherence: the
  // cells keep their members and only objects that cross a plane move); any
  // box may change arbitrarily and objects may be added or removed at the end.
  void update(const BoxArray& boxes);
  // The same update in two steps, for a caller that consumes the cells one
  // by one (the hybrid broad phase refreshes a cell right before its engine
  // reads it, while it is in the cache, instead of writing every cell in one
  // pass and reading it back from memory in the next):
  // - begin_update(boxes, allow_oversized) does everything but rewriting
  //   the cells and returns true when that is left to the caller; false when
  //   the update is complete (a build, or a frame where a cell might grow past
  //   the limit and allow_oversized is false).
  // - refresh_cell(c) then brings cell c up to date; call it exactly once per
  //   cell, before reading cell(c), from any thread, in any order.
  // - finish_update() after every cell is refreshed.
  // With allow_oversized, a cell may hold more than cell_limit objects for
  // this frame (for engines with no capacity limit); it is split at the start
  // of the next update. Between begin_update and finish_update the partition
  // is in flux: stats().entries is an upper bound, only cell_count(),
  // region(c) and refreshed cells may be read; if the caller gives up (an
  // exception), it must call reset().
  bool begin_update(const BoxArray& boxes, bool allow_oversized);
  std::span<const CellEntry> refresh_cell(std::uint32_t c);
  void finish_update();
  // Drops the tree; the next update builds from scratch.
  void reset();
  // Provisions the memory that frames of up to `objects` objects keep (the
  // cells' entry buffers, the per-object records) and faults its pages in,
  // so a first frame of that size does not pay for fresh memory.
  // CapacityExceeded from 2^32 - 1 objects on, as for a frame.
  void reserve(std::size_t objects);

  // The most entries a frame of a spread rebuild rebuilds (and the largest
  // subtree it cuts; a frame's share is otherwise a sixteenth of the tree's
  // entries, at least two full cells): 32,768 by default, about +5 ms of
  // partition on two threads at 1,024,000 paper objects. At least 2.
  void set_rebuild_budget(std::uint32_t entries);
  std::uint32_t rebuild_budget() const { return rebuild_budget_; }

  std::uint32_t cell_limit() const { return cell_limit_; }
  float x_split_weight() const { return x_split_weight_; }
  std::uint32_t cell_count() const { return static_cast<std::uint32_t>(regions_.size()); }
  // Cell c's objects (id and box), contiguous in memory, SORTED BY MIN X,
  // ties by increasing id: engines that sweep along x need no sort of their
  // own. The order is kept across frames and repaired by insertion sort.
  std::span<const CellEntry> cell(std::uint32_t c) const {
    const KdTreeNode& leaf = nodes_[leaf_nodes_[c]];
    return {entries_ + leaf.first, leaf.size};
  }
  std::uint32_t cell_size(std::uint32_t c) const { return nodes_[leaf_nodes_[c]].size; }
  const CellRegion& region(std::uint32_t c) const { return regions_[c]; }

  // The tree itself, for structures that share it (the ray tracer's two-level
  // hierarchy). Node 0 is the root; follow children from there (nodes not
  // reachable from the root are unused).
  struct NodeView {
    std::int32_t axis;    // -1: leaf
    float split;          // left: coordinate < split, right: >= split
    std::uint32_t child;  // left child (right is child + 1), internal nodes
    std::uint32_t cell;   // cell index, leaves
  };
  std::uint32_t node_count() const { return static_cast<std::uint32_t>(nodes_.size()); }
  NodeView node(std::uint32_t i) const {
    const KdTreeNode& n = nodes_[i];
    return {n.axis, n.split, n.child, n.leaf};
  }
  const PartitionStats& stats() const { return stats_; }

  // The deepest the tree may grow (root at depth 0). A leaf at this depth
  // that is still over-full stays so and is processed in tiles; every
  // traversal is safe up to it.
  static constexpr std::uint32_t kMaxDepth = 64;
  static constexpr std::uint32_t kDefaultRebuildBudget = 1u << 15;

 private:
  struct State;  // maintenance state (kd_partition.cpp)

  void rebuild(const BoxArray& boxes);
  void maintain(const BoxArray& boxes);
  void merge_sparse();
  void number_leaves();
  void find_crossings(const BoxArray& boxes);
  void bucket_additions();
  void lay_out_cells();
  void refresh_cells();
  void end_frame();
  bool split_oversized();
  void compute_stats(std::size_t objects);
  bool degraded() const;
  void plan_rebuild();
  void rebuild_step();
  void build_subtree(std::uint32_t k);
  std::uint64_t splice_subtree(std::uint32_t k);
  void compact_nodes();

  std::uint32_t cell_limit_;
  std::uint32_t rebuild_budget_ = kDefaultRebuildBudget;
  float x_split_weight_;
  CellCost cell_cost_;
  std::vector<KdTreeNode> nodes_;
  std::vector<std::uint32_t> leaf_nodes_;  // cell -> node
  std::vector<CellRegion> regions_;        // cell -> region
  const CellEntry* entries_ = nullptr;     // this frame's cell entries (owned by state_)
  std::unique_ptr<State> state_;
  PartitionStats stats_;
};

}  // namespace hbp
