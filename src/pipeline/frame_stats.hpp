// SPDX-License-Identifier: MIT
#pragma once
// FrameStats' partition fields, from the partition's own stats or, on a
// frame the partition never saw (one cell), for that one cell.
#include <cstdint>

#include "hbp/hybrid_broadphase.hpp"
#include "hbp/kd_partition.hpp"

namespace hbp::detail {

inline void set_partition_stats(FrameStats& s, const PartitionStats& ps) {
  s.cells = ps.cells;
  s.min_cell = ps.min_cell;
  s.median_cell = ps.median_cell;
  s.max_cell = ps.max_cell;
  s.duplication = ps.duplication;
  s.oversized_cells = ps.oversized_cells;
  s.rebuilt = ps.rebuilt;
  s.rebuilt_subtrees = ps.rebuilt_subtrees;
  s.rebuilt_entries = ps.rebuilt_entries;
  s.splits = ps.splits;
  s.merges = ps.merges;
}

// One cell of n objects, no tree.
inline void set_one_cell_stats(FrameStats& s, std::uint32_t n) {
  s.cells = 1;
  s.min_cell = s.median_cell = s.max_cell = n;
  s.duplication = 1.0;
  s.oversized_cells = 0;
  s.rebuilt = false;
  s.rebuilt_subtrees = 0;
  s.rebuilt_entries = 0;
  s.splits = s.merges = 0;
}

}  // namespace hbp::detail
