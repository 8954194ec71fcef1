// SPDX-License-Identifier: MIT
// The CPU launcher of the GPU frame: the kernels' bodies (frame_bodies.hpp)
// run stage by stage as device_frame.cu runs them, blocks spread over
// FrameOptions::threads CPU threads. Buffers are members kept across frames:
// a steady frame allocates nothing (vectors only grow; see keep_bounded).
#include <algorithm>
#include <chrono>
#include <cstdint>
#include <vector>

#include "cuda/frame_bodies.hpp"
#include "cuda/frame_impl.hpp"
#include "cuda/grid_plan.hpp"
#include "cuda/host_blocks.hpp"
#include "cuda/host_radix.hpp"

namespace hbp::cuda {
namespace {

using Clock = std::chrono::steady_clock;
double ms_since(Clock::time_point& t) {
  const auto now = Clock::now();
  const double ms = std::chrono::duration<double, std::milli>(now - t).count();
  t = now;
  return ms;
}

class HostFrame final : public FrameBroadPhase::Impl {
 public:
  using Impl::Impl;

  void run(const Lanes& in) override {
    info = {};
    const std::uint32_t n = in.n;
    const BoxLanesView b{{in.lo[0], in.lo[1], in.lo[2]}, {in.hi[0], in.hi[1], in.hi[2]}};
    const unsigned threads = options.threads;
    auto t = Clock::now();
    const auto t0 = t;

    // The grid from the last frame's bounds when it had as many objects
    // (GridPlan::update_from_last), as the device plans it.
    const bool lagged = grid_.update_from_last(n, options.boxes_per_cell, options.cell_shape, info.replanned);

    // Bounds, extents and validation: per-thread slices, combined in slice
    // order.
    Bounds bounds{{0, 0, 0}, {0, 0, 0}};
    ExtentHistogram& extents = slice_extents_[kSlices];
    extents = {};
    if (n) {
      Bounds part[kSlices];
      std::uint32_t bad[kSlices];
      for_blocks(threads, kSlices, [&](std::uint64_t s) {
        ExtentHistogram& h = slice_extents_[s];
        h = {};
        const std::uint32_t lo = static_cast<std::uint32_t>(n * s / kSlices);
        const std::uint32_t hi = static_cast<std::uint32_t>(n * (s + 1) / kSlices);
        Bounds p{{__builtin_huge_valf(), __builtin_huge_valf(), __builtin_huge_valf()},
                 {-__builtin_huge_valf(), -__builtin_huge_valf(), -__builtin_huge_valf()}};
        bad[s] = n;
        for (std::uint32_t i = lo; i < hi; ++i) {
          if (box_defect(b, i)) {
            bad[s] = i;
            break;
          }
          for (int k = 0; k < 3; ++k) {
            p.lo[k] = std::min(p.lo[k], b.lo[k][i]);
            p.hi[k] = std::max(p.hi[k], b.hi[k][i]);
            ++h.count[k][extent_bin(b.lo[k][i], b.hi[k][i])];
          }
        }
        part[s] = p;
      });
      bounds = part[0];
      for (std::uint32_t s = 0; s < kSlices; ++s) {
        if (bad[s] < n) throw_box_defect(bad[s], box_defect(b, bad[s]));
        for (int k = 0; k < 3; ++k) {
          bounds.lo[k] = std::min(bounds.lo[k], part[s].lo[k]);
          bounds.hi[k] = std::max(bounds.hi[k], part[s].hi[k]);
          for (std::uint32_t bin = 0; bin < kExtentBins; ++bin) extents.count[k][bin] += slice_extents_[s].count[k][bin];
        }
      }
    }
    if (!lagged) info.replanned = grid_.update(bounds, extents, n, options.boxes_per_cell, options.cell_shape);
    grid_.remember(bounds, extents, n);
    const GridView g = grid_.view(grid_.planes().data());
    for (int k = 0; k < 3; ++k) info.grid[k] = g.dims[k];
    info.times.bounds_ms = ms_since(t);

    // References: count, scan, emit; the large boxes listed apart.
    grow(ref_count_, n);
    grow(is_large_, n);
    for_blocks(threads, n, [&](std::uint64_t i) {
      const std::uint32_t c = reference_count(g, b, static_cast<std::uint32_t>(i));
      ref_count_[i] = c;
      is_large_[i] = c == 0;
    });
    grow(ref_offset_, n);
    std::uint32_t refs = 0;
    large_.clear();
    for (std::uint32_t i = 0; i < n; ++i) {
      ref_offset_[i] = refs;
      refs += ref_count_[i];
      if (is_large_[i]) large_.push_back(i);
    }
    const auto large = static_cast<std::uint32_t>(large_.size());
    info.references = refs;
    info.large = large;
    grow(keys_, refs);
    grow(ids_, refs);
    const int bits = position_bits(grid_.cells());
    for_blocks(threads, n, [&](std::uint64_t i) {
      if (!is_large_[i])
        emit_references(g, b, static_cast<std::uint32_t>(i), bits, keys_.data(), ids_.data(), ref_offset_[i]);
    });
    info.times.refs_ms = ms_since(t);

    // Sort by key (cell, position of min x), gather the sorted lanes; the
    // keys go with them whole (reference_row reads each row's cell from its
    // key), and the cells are counted.
    radix_sort(keys_, key_scratch_, &ids_, &id_scratch_, key_bits(grid_.cells()));
    for (auto* lane : {&s_lo_[0], &s_lo_[1], &s_lo_[2], &s_hi_[0], &s_hi_[1], &s_hi_[2]}) grow(*lane, refs);
    grow(positions_, refs);
    for_blocks(threads, refs, [&](std::uint64_t r) {
      for (int k = 0; k < 3; ++k) {
        s_lo_[k][r] = b.lo[k][ids_[r]];
        s_hi_[k][r] = b.hi[k][ids_[r]];
      }
      positions_[r] = static_cast<std::uint32_t>(keys_[r]);
    });
    std::uint32_t cells = 0;
    for (std::uint32_t r = 0; r < refs; ++r) cells += r == 0 || (keys_[r] >> bits) != (keys_[r - 1] >> bits);
    info.cells = cells;
    info.times.sort_ms = ms_since(t);

    // Count: one slot per lane, then one per (large box, chunk of partners).
    const CellLanes s{{s_lo_[0].data(), s_lo_[1].data(), s_lo_[2].data()},
                      {s_hi_[0].data(), s_hi_[1].data(), s_hi_[2].data()},
                      ids_.data(),
                      positions_.data()};
    const std::uint32_t chunk = large_chunk(n, large);
    const std::uint32_t chunks = large ? (n + chunk - 1) / chunk : 0;
    const std::uint64_t slots = std::uint64_t{refs} + std::uint64_t{large} * chunks;
    grow(pair_offset_, slots + 1);
    auto noop = [](std::uint32_t, std::uint32_t, std::uint32_t) {};
    for_blocks(threads, refs, [&](std::uint64_t r) {
      pair_offset_[r] = reference_row(g, s, bits, static_cast<std::uint32_t>(r), refs, noop);
    });
    for_blocks(threads, std::uint64_t{large} * chunks, [&](std::uint64_t q) {
      const std::uint32_t j0 = static_cast<std::uint32_t>(q % chunks) * chunk;
      pair_offset_[refs + q] = large_row(b, is_large_.data(), large_[q / chunks], j0, std::min(n, j0 + chunk), noop);
    });
    std::uint64_t total = 0;
    for (std::uint64_t q = 0; q < slots; ++q) total += std::exchange(pair_offset_[q], total);
    pair_offset_[slots] = total;
    info.times.count_ms = ms_since(t);
    if (options.max_pairs && total > options.max_pairs) throw_too_many_pairs(total, options.max_pairs);

    // Fill: the same rows, each writing from its offset.
    grow(pairs, total);
    Pair* out = pairs.data();
    for_blocks(threads, refs, [&](std::uint64_t r) {
      Pair* row = out + pair_offset_[r];
      reference_row(g, s, bits, static_cast<std::uint32_t>(r), refs,
                    [row](std::uint32_t k, std::uint32_t a, std::uint32_t bb) { row[k] = make_pair(a, bb); });
    });
    for_blocks(threads, std::uint64_t{large} * chunks, [&](std::uint64_t q) {
      const std::uint32_t j0 = static_cast<std::uint32_t>(q % chunks) * chunk;
      Pair* row = out + pair_offset_[refs + q];
      large_row(b, is_large_.data(), large_[q / chunks], j0, std::min(n, j0 + chunk),
                [row](std::uint32_t k, std::uint32_t a, std::uint32_t bb) { row[k] = make_pair(a, bb); });
    });
    info.pairs = total;
    info.times.fill_ms = ms_since(t);

    if (options.sorted && total > 1) {
      grow(pair_keys_, total);
      for_blocks(threads, total, [&](std::uint64_t p) {
        pair_keys_[p] = (std::uint64_t{pairs[p].a} << 32) | pairs[p].b;
      });
      radix_sort(pair_keys_, pair_key_scratch_, nullptr, nullptr, 64);
      for_blocks(threads, total, [&](std::uint64_t p) {
        pairs[p] = Pair{static_cast<std::uint32_t>(pair_keys_[p] >> 32), static_cast<std::uint32_t>(pair_keys_[p])};
      });
    }
    info.times.order_ms = ms_since(t);
    info.times.frame_ms = std::chrono::duration<double, std::milli>(t - t0).count();
    info.buffer_bytes = bytes();
  }

 void reserve(std::uint32_t n) override {
    // The typical frame's sizes (device_frame.cu's estimate): about two
    // references and under two pairs per object.
    const std::uint64_t refs = 2ull * n;
    grow(ref_count_, n), grow(is_large_, n), grow(ref_offset_, n);
    grow(keys_, refs), grow(key_scratch_, refs), grow(ids_, refs), grow(id_scratch_, refs);
    for (int k = 0; k < 3; ++k) grow(s_lo_[k], refs), grow(s_hi_[k], refs);
    grow(positions_, refs);
    grow(pair_offset_, refs + 1);
    grow(pairs, refs);
    pairs.clear();  // no frame yet
    if (options.sorted) grow(pair_keys_, refs), grow(pair_key_scratch_, refs);
    info = {};
  }

 private:
  // Resizes a kept buffer to n: past its capacity it grows to n + n/8 (counted
  // in info.allocations; the eighth absorbs the frame-to-frame jitter of the
  // reference and pair counts), and it is given back when it holds more than
  // four times what the frame needs beyond 1 M entries, so memory follows the
  // current frame's needs while steady frames allocate nothing.
  template <class V>
  void grow(V& v, std::uint64_t n) {
    if (v.capacity() > 4 * n + (1u << 20)) {
      V().swap(v);
    }
    if (n > v.capacity()) {
      ++info.allocations;
      v.reserve(n + n / 8 + 64);
    }
    v.resize(n);
  }
  std::uint64_t bytes() const {
    std::uint64_t sum = 0;
    auto add = [&](const auto& v) { sum += v.capacity() * sizeof(v[0]); };
    add(ref_count_), add(is_large_), add(ref_offset_), add(large_), add(keys_), add(key_scratch_), add(ids_);
    add(id_scratch_), add(positions_), add(pair_offset_), add(pair_keys_), add(pair_key_scratch_);
    add(pairs);
    for (int k = 0; k < 3; ++k) add(s_lo_[k]), add(s_hi_[k]);
    return sum;
  }

  static constexpr std::uint32_t kSlices = 64;
  GridPlan grid_;
  std::vector<ExtentHistogram> slice_extents_ = std::vector<ExtentHistogram>(kSlices + 1);  // + the total
  std::vector<std::uint32_t> ref_count_, ref_offset_, large_, ids_, id_scratch_, positions_;
  std::vector<std::uint8_t> is_large_;
  std::vector<std::uint64_t> keys_, key_scratch_, pair_offset_, pair_keys_, pair_key_scratch_;
  std::vector<float> s_lo_[3], s_hi_[3];
};

}  // namespace

std::unique_ptr<FrameBroadPhase::Impl> make_host_frame(const FrameOptions& options) {
  return std::make_unique<HostFrame>(options);
}

}  // namespace hbp::cuda
