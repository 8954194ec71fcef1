// SPDX-License-Identifier: MIT
#pragma once
// One cell through the accelerator's body (the hybrid system's call): the
// cell's boxes sorted by min x, a lane per box sweeping forward with the
// ownership rule fused in, counted first so the pair limit is checked
// before a pair is written. Scratch kept by the caller (an engine is used
// by one thread at a time), so a steady frame allocates nothing.
#include <cstdint>
#include <vector>

#include "hbp/box_array.hpp"
#include "hbp/cell_region.hpp"
#include "hbp/pair.hpp"

namespace hbp::cuda {

class CellSweep {
 public:
  // Appends the owned pairs of `cell` (local indices, canonical). When
  // `sorted_x` the cell is already sorted by min x (the hybrid system's
  // call); otherwise it is sorted here first. CapacityExceeded when the cell
  // has more than `pair_limit` pairs, before any is appended.
  void run(const BoxArray& cell, bool sorted_x, const CellRegion& region, std::uint64_t pair_limit,
           std::vector<Pair>& out);

  // The sorted lanes last run (for the device engine, which uploads them).
  std::uint32_t size() const { return n_; }
  const float* lo(int k) const { return lo_[k]; }
  const float* hi(int k) const { return hi_[k]; }
  const std::uint32_t* ids() const { return ids_.data(); }

  // Sorts `cell` by min x into the kept lanes (stable: ties keep index order).
  void sort(const BoxArray& cell, bool sorted_x);

 private:
  std::uint32_t n_ = 0;
  const float* lo_[3] = {};
  const float* hi_[3] = {};
  std::vector<std::uint64_t> keys_, key_scratch_, counts_;
  std::vector<std::uint32_t> ids_, id_scratch_;
  std::vector<float> sorted_[6];
};

}  // namespace hbp::cuda
