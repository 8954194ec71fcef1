// SPDX-License-Identifier: MIT
#pragma once
// One cell's boxes as the engines take them: structure of arrays in min-x
// order (ties by position, which is by id), padded, with each box's global id
// beside it. The partition may already deliver a cell in that order; then the
// sort is skipped (checked, never assumed), and the result is identical.
#include <cstdint>
#include <span>
#include <vector>

#include "hbp/box_array.hpp"
#include "hbp/kd_partition.hpp"

namespace hbp {

class OrderedCell {
 public:
  // From the partition's entries of one cell.
  void load(std::span<const CellEntry> entries);
  // From a whole frame, ids = indices (the one-cell path for small worlds).
  void load(const BoxArray& frame);

  const BoxArray& boxes() const { return boxes_; }
  // ids()[k] is the id of box k; readable up to size() + 16 (padding).
  const std::uint32_t* ids() const { return ids_.data(); }
  std::uint32_t size() const { return static_cast<std::uint32_t>(boxes_.size()); }
  // Whether the last load found its input already in min-x order.
  bool was_sorted() const { return was_sorted_; }

 private:
  void fit(std::uint32_t n);

  BoxArray boxes_;
  std::vector<std::uint32_t> ids_;
  std::vector<std::uint32_t> order_;
  std::vector<std::uint64_t> scratch_;
  bool was_sorted_ = false;
};

}  // namespace hbp
