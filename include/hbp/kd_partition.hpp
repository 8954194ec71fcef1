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
// Routing uses half-open cell regions: a box goes left when min < split and
// right when max >= split.
#include <cstdint>
#include <functional>
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
  std::uint32_t splits = 0, merges = 0;
};

// One object's membership of one cell: a copy of its box, so engines never
// chase ids into the frame's arrays. 32 bytes: one write stream per cell when
// the partition scatters entries.
struct CellEntry {
  float min[3];
  float max[3];
  std::uint32_t id;
  std::uint32_t unused;
};

class KdPartition {
 public:
  // x_split_weight scales the x spread when choosing the split axis (< 1
  // favours splitting y and z: cells longer in x, for a sweep along x).
  // cell_cost, when given, is the engine's cost of one cell of n objects
  // (the hardware models' cycles): a leaf under the limit is still split while
  // that lowers the summed cost (duplicates included), and sibling leaves are
  // merged when that does not raise it.
  using CellCost = std::function<double(std::uint32_t n)>;
  explicit KdPartition(std::uint32_t cell_limit, float x_split_weight = 1.0f, CellCost cell_cost = {});

  // Partitions a frame. Boxes must be valid (no NaN, min <= max). Object i of
  // this frame is assumed to be object i of the previous one (coherence).
  void update(const BoxArray& boxes);
  // Drops the tree; the next update builds from scratch.
  void reset();

  std::uint32_t cell_limit() const { return cell_limit_; }
  std::uint32_t cell_count() const { return static_cast<std::uint32_t>(regions_.size()); }
  // Cell c's objects (id and box), by increasing id, contiguous in memory.
  std::span<const CellEntry> cell(std::uint32_t c) const {
    const Node& leaf = nodes_[leaf_nodes_[c]];
    return {entries_.data() + leaf.first, leaf.size};
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
    const Node& n = nodes_[i];
    return {n.axis, n.split, n.child, n.leaf};
  }
  const PartitionStats& stats() const { return stats_; }

 private:
  struct Node {
    float split = 0;
    std::int32_t axis = -1;    // -1: leaf
    std::uint32_t child = 0;   // left child; right child is child + 1
    std::uint32_t leaf = 0;    // cell index when a leaf
    std::uint32_t size = 0;    // leaves: entries routed here (this frame once routed)
    std::uint32_t first = 0;   // leaves: position of the first entry in entries_
    std::uint32_t epoch = 0;   // numbering pass that last reached this node
  };
  static constexpr std::uint32_t kNoHome = 0xFFFFFFFFu;

  void build(std::vector<std::uint32_t>& ids);
  void build_node(std::uint32_t node, std::vector<std::uint32_t>& ids, std::uint32_t depth);
  void route_all();
  bool split_oversized();
  void route_subtree(std::uint32_t node, const std::vector<CellEntry>& entries);
  void merge_sparse();
  void number_leaves();
  void compute_stats();

  std::uint32_t cell_limit_;
  float x_split_weight_;
  CellCost cell_cost_;
  const BoxArray* boxes_ = nullptr;  // the frame being partitioned
  std::vector<Node> nodes_;
  std::vector<CellRegion> node_regions_;   // per node, valid for live nodes
  std::vector<std::uint32_t> home_;        // object -> root of the subtree holding its cells
  std::uint32_t epoch_ = 0;
  std::vector<CellEntry> entries_;         // leaf after leaf (split leaves' at the end)
  std::vector<CellRegion> regions_;        // cell -> region
  std::vector<std::uint32_t> leaf_nodes_;  // cell -> node
  std::vector<std::vector<std::uint64_t>> chunk_routes_;
  std::vector<std::uint32_t> chunk_counts_;
  std::vector<float> scratch_;
  PartitionStats stats_;
  double rebuild_duplication_ = 0;
  std::uint32_t rebuild_cells_ = 0;
};

}  // namespace hbp
