#pragma once
// The processor's spatial partition: a k-d tree whose leaves ("cells") hold at
// most `cell_limit` objects. An object straddling a split plane is placed in
// every cell it overlaps. The tree is kept across frames: objects are routed
// through the existing planes, over-full leaves are split, sparse sibling
// leaves merged, and the tree is rebuilt when its quality degrades.
//
// Split rule: median of box centres on the axis of largest centre spread; if
// that split does not shrink both children, the other axes are tried; if none
// does (identical or nested boxes), the leaf stays over-full and the engines
// process it in tiles.
//
// Routing uses half-open cell regions: a box goes left when min < split and
// right when max >= split. Every cell is listed in increasing min-x order.
#include <cstdint>
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

class KdPartition {
 public:
  explicit KdPartition(std::uint32_t cell_limit);

  // Partitions a frame. Boxes must be valid (no NaN, min <= max).
  void update(const BoxArray& boxes);
  // Drops the tree; the next update builds from scratch.
  void reset();

  std::uint32_t cell_limit() const { return cell_limit_; }
  std::uint32_t cell_count() const { return static_cast<std::uint32_t>(regions_.size()); }
  // Positions into sorted_boxes() of the objects in cell c, increasing.
  std::span<const std::uint32_t> cell(std::uint32_t c) const {
    return {entries_.data() + offsets_[c], entries_.data() + offsets_[c + 1]};
  }
  const CellRegion& region(std::uint32_t c) const { return regions_[c]; }
  // The frame's boxes in increasing min-x order, and the object id of each.
  const BoxArray& sorted_boxes() const { return sorted_; }
  const std::vector<std::uint32_t>& sorted_ids() const { return ids_; }
  const PartitionStats& stats() const { return stats_; }

 private:
  struct Node {
    float split = 0;
    std::int32_t axis = -1;    // -1: leaf
    std::uint32_t child = 0;   // left child; right child is child + 1
    std::uint32_t leaf = 0;    // cell index when a leaf
    std::uint32_t size = 0;    // entries routed here last frame (leaves)
  };

  void sort_by_min_x(const BoxArray& boxes);
  void build(std::vector<std::uint32_t>& positions);
  void build_node(std::uint32_t node, std::vector<std::uint32_t>& positions, std::uint32_t depth);
  void route_all();
  void split_oversized();
  void merge_sparse();
  void number_leaves();
  void collect_entries();
  void compute_stats();

  std::uint32_t cell_limit_;
  std::vector<Node> nodes_;
  // Routing results per leaf node (node index -> positions), rebuilt each frame.
  std::vector<std::vector<std::uint32_t>> leaf_lists_;
  std::vector<std::uint32_t> leaf_nodes_;  // cell index -> node index
  std::vector<std::uint32_t> offsets_;
  std::vector<std::uint32_t> entries_;
  std::vector<CellRegion> regions_;
  BoxArray sorted_;
  std::vector<std::uint32_t> ids_;
  std::vector<std::uint32_t> keys_, keys_tmp_, ids_tmp_;
  std::vector<std::vector<std::uint64_t>> chunk_routes_;
  std::vector<float> scratch_;
  PartitionStats stats_;
  double rebuild_duplication_ = 0;
  std::uint32_t rebuild_cells_ = 0;
  std::uint32_t frames_since_rebuild_ = 0;
};

}  // namespace hbp
