// SPDX-License-Identifier: MIT
#include "cuda/cell_sweep.hpp"

#include <numeric>
#include <string>

#include "cuda/frame_bodies.hpp"
#include "cuda/host_radix.hpp"
#include "hbp/error.hpp"

namespace hbp::cuda {

void CellSweep::sort(const BoxArray& cell, bool sorted_x) {
  n_ = static_cast<std::uint32_t>(cell.size());
  ids_.resize(n_);
  std::iota(ids_.begin(), ids_.end(), 0u);
  if (sorted_x) {
    for (int k = 0; k < 3; ++k) {
      lo_[k] = cell.min(k);
      hi_[k] = cell.max(k);
    }
    return;
  }
  keys_.resize(n_);
  for (std::uint32_t i = 0; i < n_; ++i) keys_[i] = ordered_bits(cell.min(0)[i]);
  radix_sort(keys_, key_scratch_, &ids_, &id_scratch_, 32);
  for (int l = 0; l < 6; ++l) {
    const float* src = l < 3 ? cell.min(l) : cell.max(l - 3);
    sorted_[l].resize(n_);
    for (std::uint32_t i = 0; i < n_; ++i) sorted_[l][i] = src[ids_[i]];
  }
  for (int k = 0; k < 3; ++k) {
    lo_[k] = sorted_[k].data();
    hi_[k] = sorted_[3 + k].data();
  }
}

void CellSweep::run(const BoxArray& cell, bool sorted_x, const CellRegion& region, std::uint64_t pair_limit,
                    std::vector<Pair>& out) {
  sort(cell, sorted_x);
  const SortedLanes s{{lo_[0], lo_[1], lo_[2]}, {hi_[0], hi_[1], hi_[2]}, ids_.data()};
  counts_.resize(n_);
  std::uint64_t total = 0;
  for (std::uint32_t r = 0; r < n_; ++r) {
    counts_[r] = total;
    total += sweep_row(s, r, n_, region, [](std::uint32_t, std::uint32_t, std::uint32_t) {});
  }
  if (total > pair_limit)
    throw CapacityExceeded("cell of " + std::to_string(n_) + " boxes has more than " + std::to_string(pair_limit) +
                           " overlapping pairs (max_pairs)");
  const std::size_t base = out.size();
  out.resize(base + total);
  Pair* dst = out.data() + base;
  for (std::uint32_t r = 0; r < n_; ++r) {
    Pair* row = dst + counts_[r];
    sweep_row(s, r, n_, region, [row](std::uint32_t k, std::uint32_t a, std::uint32_t b) { row[k] = make_pair(a, b); });
  }
}

}  // namespace hbp::cuda
