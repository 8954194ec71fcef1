#include "pipeline/ordered_cell.hpp"

#include <algorithm>
#include <cstring>
#include <numeric>

#include "engines/min_x_order.hpp"

namespace hbp {

namespace {

constexpr std::uint32_t kIdPadding = 16;  // the kernels read ids a vector past the end
// Buffers sized for an over-full cell are released once cells are this much
// smaller again (memory follows the current frame, not the largest cell ever).
constexpr std::size_t kKeepSlack = 4;
constexpr std::size_t kKeepAlways = 1 << 16;

void copy_entries(const CellEntry* entries, const std::uint32_t* order, std::uint32_t n, BoxArray& dst,
                  std::uint32_t* ids) {
  float* d[6] = {dst.min(0), dst.min(1), dst.min(2), dst.max(0), dst.max(1), dst.max(2)};
  for (std::uint32_t i = 0; i < n; ++i) {
    const CellEntry& e = entries[order ? order[i] : i];
    d[0][i] = e.min[0];
    d[1][i] = e.min[1];
    d[2][i] = e.min[2];
    d[3][i] = e.max[0];
    d[4][i] = e.max[1];
    d[5][i] = e.max[2];
    ids[i] = e.id;
  }
}

}  // namespace

void OrderedCell::fit(std::uint32_t n) {
  if (boxes_.capacity() > kKeepSlack * n + kKeepAlways) {
    boxes_ = BoxArray();
    std::vector<std::uint32_t>().swap(ids_);
    std::vector<std::uint32_t>().swap(order_);
    std::vector<std::uint64_t>().swap(scratch_);
  }
  boxes_.resize(n);
  ids_.resize(std::size_t{n} + kIdPadding);
}

void OrderedCell::load(std::span<const CellEntry> entries) {
  const auto n = static_cast<std::uint32_t>(entries.size());
  fit(n);
  copy_entries(entries.data(), nullptr, n, boxes_, ids_.data());
  was_sorted_ = in_min_x_order(boxes_.min(0), n);
  if (was_sorted_) return;
  min_x_order(boxes_.min(0), n, order_, scratch_);
  copy_entries(entries.data(), order_.data(), n, boxes_, ids_.data());
}

void OrderedCell::load(const BoxArray& frame) {
  const auto n = static_cast<std::uint32_t>(frame.size());
  fit(n);
  was_sorted_ = in_min_x_order(frame.min(0), n);
  if (n == 0) return;  // an empty frame's lanes may be null: nothing to copy
  if (was_sorted_) {
    for (int k = 0; k < 3; ++k) {
      std::memcpy(boxes_.min(k), frame.min(k), sizeof(float) * n);
      std::memcpy(boxes_.max(k), frame.max(k), sizeof(float) * n);
    }
    std::iota(ids_.begin(), ids_.begin() + n, 0u);
    return;
  }
  min_x_order(frame.min(0), n, order_, scratch_);
  for (int k = 0; k < 3; ++k) {
    const float* lo = frame.min(k);
    const float* hi = frame.max(k);
    float* dlo = boxes_.min(k);
    float* dhi = boxes_.max(k);
    for (std::uint32_t i = 0; i < n; ++i) {
      dlo[i] = lo[order_[i]];
      dhi[i] = hi[order_[i]];
    }
  }
  std::copy(order_.begin(), order_.end(), ids_.begin());
}

}  // namespace hbp
