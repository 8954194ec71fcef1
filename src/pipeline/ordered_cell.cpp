// SPDX-License-Identifier: MIT
#include "pipeline/ordered_cell.hpp"

#include <algorithm>
#include <cstddef>
#include <cstring>
#include <numeric>

#include "engines/min_x_order.hpp"
#include "support/retained.hpp"

#if defined(__SSE2__)
#include <immintrin.h>
#endif

namespace hbp {

namespace {

constexpr std::uint32_t kIdPadding = 16;  // the kernels read ids a vector past the end

// One entry's eight words to the six box lanes and the id lane.
inline void copy_entry(const CellEntry& e, float* const d[6], std::uint32_t* ids, std::uint32_t i) {
  d[0][i] = e.min[0];
  d[1][i] = e.min[1];
  d[2][i] = e.min[2];
  d[3][i] = e.max[0];
  d[4][i] = e.max[1];
  d[5][i] = e.max[2];
  ids[i] = e.id;
}

// Entries (32 bytes each, in cell order or through `order`) to the cell's
// structure-of-arrays lanes. Four entries at a time as two 4x4 transposes
// of their halves (SSE2, part of x86-64): about half the loads and stores
// of an entry-by-entry copy.
void copy_entries(const CellEntry* entries, const std::uint32_t* order, std::uint32_t n, BoxArray& dst,
                  std::uint32_t* ids) {
  float* const d[6] = {dst.min(0), dst.min(1), dst.min(2), dst.max(0), dst.max(1), dst.max(2)};
  std::uint32_t i = 0;
#if defined(__SSE2__)
  static_assert(sizeof(CellEntry) == 32 && offsetof(CellEntry, max) == 12 && offsetof(CellEntry, id) == 24);
  for (; i + 4 <= n; i += 4) {
    const CellEntry* e[4];
    for (int k = 0; k < 4; ++k) e[k] = entries + (order ? order[i + k] : i + k);
    // Rows {min x, min y, min z, max x} and {max y, max z, id, tag}.
    __m128 a0 = _mm_loadu_ps(e[0]->min), a1 = _mm_loadu_ps(e[1]->min), a2 = _mm_loadu_ps(e[2]->min),
           a3 = _mm_loadu_ps(e[3]->min);
    __m128 b0 = _mm_loadu_ps(e[0]->max + 1), b1 = _mm_loadu_ps(e[1]->max + 1), b2 = _mm_loadu_ps(e[2]->max + 1),
           b3 = _mm_loadu_ps(e[3]->max + 1);
    _MM_TRANSPOSE4_PS(a0, a1, a2, a3);
    _MM_TRANSPOSE4_PS(b0, b1, b2, b3);
    _mm_storeu_ps(d[0] + i, a0);
    _mm_storeu_ps(d[1] + i, a1);
    _mm_storeu_ps(d[2] + i, a2);
    _mm_storeu_ps(d[3] + i, a3);
    _mm_storeu_ps(d[4] + i, b0);
    _mm_storeu_ps(d[5] + i, b1);
    _mm_storeu_si128(reinterpret_cast<__m128i*>(ids + i), _mm_castps_si128(b2));
  }
#endif
  for (; i < n; ++i) copy_entry(entries[order ? order[i] : i], d, ids, i);
}

}  // namespace

void OrderedCell::fit(std::uint32_t n) {
  // Sized for an over-full cell: released by the retained rule.
  if (retained::oversized(boxes_.capacity(), n, retained::kSlack<Aabb>)) {
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
