// SPDX-License-Identifier: MIT
#include "pipeline/first_frame_sample.hpp"

#include <tbb/parallel_for.h>

#include <algorithm>
#include <atomic>
#include <cstdint>

namespace hbp::detail {

namespace {

constexpr std::uint32_t kFirstFrameSampleStride = 8;
constexpr std::size_t kFirstFrameMargin = 32;

}  // namespace

std::size_t sample_frame_pairs(const KdPartition& partition, tbb::enumerable_thread_specific<Worker>& workers) {
  const std::uint32_t cells = partition.cell_count();
  if (cells < 2 * kFirstFrameSampleStride) return 0;
  const std::uint32_t samples = cells / kFirstFrameSampleStride;
  std::atomic<std::uint64_t> sample_pairs{0}, sample_entries{0};
  tbb::parallel_for(tbb::blocked_range<std::uint32_t>(0, samples, 1), [&](const auto& r) {
    Worker& w = workers.local();
    std::uint64_t p = 0, e = 0;
    for (std::uint32_t k = r.begin(); k != r.end(); ++k) {
      const std::uint32_t c = k * kFirstFrameSampleStride + kFirstFrameSampleStride / 2;
      const CellRegion& region = partition.region(c);
      load_cell(w, partition.cell(c), region);
      p += w.direct->count_pairs(w.cell.boxes(), w.cell.ids(), w.codes.data(), region, 0);
      e += w.cell.size();
    }
    sample_pairs.fetch_add(p, std::memory_order_relaxed);
    sample_entries.fetch_add(e, std::memory_order_relaxed);
  });
  std::uint64_t entries = 0, bound = 0;
  for (std::uint32_t c = 0; c < cells; ++c) {
    const std::uint64_t n = partition.cell(c).size();
    entries += n;
    bound += n * (n - (n > 0)) / 2;
  }
  if (sample_entries == 0 || sample_pairs == 0) return 0;
  const double scaled =
      static_cast<double>(sample_pairs) * static_cast<double>(entries) / static_cast<double>(sample_entries.load());
  auto estimate = static_cast<std::size_t>(scaled);
  return static_cast<std::size_t>(
      std::min<std::uint64_t>(estimate + estimate / kFirstFrameMargin + kKeepCellPairs, bound));
}

}  // namespace hbp::detail
