// SPDX-License-Identifier: MIT
#pragma once
// The bodies of the GPU frame's kernels, written once as host/device
// functions: device_frame.cu launches them as CUDA kernels, host_frame.cpp
// and host_cell_engine.cpp run them on CPU threads. Every decision that
// picks a cell or a pair is a float comparison against stored values (the
// grid's planes, the boxes' own coordinates), never arithmetic, so host and
// device agree bit for bit (the device is compiled with --fmad=false too).
#include <cstdint>

#include "dedup/ownership.hpp"
#include "geometry/box_screen.hpp"
#include "hbp/cell_region.hpp"
#include "hbp/host_device.hpp"

namespace hbp::cuda {

// A box whose cell range covers more than this many cells is "large": it is
// not replicated into cells but tested against every box by the large pass,
// so replication (and memory) stays below kMaxRefsPerBox references per box
// whatever the scene (boxes spanning the world included).
inline constexpr std::uint32_t kMaxRefsPerBox = 8;
// Grid limits: cell ids fit 22 bits (the sort key's high word), each axis
// at most 1024 cells.
inline constexpr std::uint32_t kMaxAxisCells = 1024;
inline constexpr std::uint32_t kMaxCells = 1u << 22;

// Box extents by binary order of magnitude, per axis: an extent's bin is its
// float's biased exponent. The histogram is exact integer counts, the same on
// every launcher and in any order of accumulation, and bounds each bin's
// extents within a factor of two; the grid plans cells no narrower than
// nearly every box (grid_plan.hpp), so replication stays low and the large
// pass rare in dense and flat scenes alike.
inline constexpr std::uint32_t kExtentBins = 256;
HBP_HOST_DEVICE inline std::uint32_t extent_bin(float lo, float hi) {
  const float e = hi - lo;  // >= 0 for a valid box; +inf past the float range (bin 255)
  std::uint32_t u;
  __builtin_memcpy(&u, &e, sizeof u);
  return (u >> 23) & 0xffu;
}

// The uniform grid of one frame (cuda/grid_plan.hpp plans it): on axis k,
// dims[k] cells cut by dims[k] - 1 increasing interior planes. The outer
// cells reach to infinity, so the regions tile all space and every box,
// inside the planned bounds or not, lands in the cells its extent meets.
struct GridView {
  std::uint32_t dims[3];
  const float* planes[3];  // dims[k] - 1 floats each
  float x_lo, x_hi;        // the planned bounds on x: the outer x slabs' finite ends for slab_position
};

// The boxes by object index (structure of arrays).
struct BoxLanesView {
  const float* lo[3];
  const float* hi[3];
};

// References sorted by (cell, min x), gathered into contiguous lanes; id is
// the object index of each reference.
struct SortedLanes {
  const float* lo[3];
  const float* hi[3];
  const std::uint32_t* id;
};

// The frame's references in key order (cell, slab_position of min x),
// gathered into lanes, with each reference's position (its key's low bits).
struct CellLanes {
  const float* lo[3];
  const float* hi[3];
  const std::uint32_t* id;
  const std::uint32_t* position;
};

// Number of planes <= v (binary search): the index of the cell whose
// half-open slab [plane[c-1], plane[c]) holds v.
HBP_HOST_DEVICE inline std::uint32_t slab_of(const float* planes, std::uint32_t count, float v) {
  std::uint32_t first = 0;
  while (count > 0) {
    const std::uint32_t half = count / 2;
    if (planes[first + half] <= v) {
      first += half + 1;
      count -= half + 1;
    } else {
      count = half;
    }
  }
  return first;
}

// The cells a box meets on each axis: [first[k], last[k]], i.e. every cell
// whose region [lo, hi) satisfies lo <= max and hi > min. The ownership point
// of any pair holding the box lies in [min, max], so the cell that owns the
// pair is among these.
HBP_HOST_DEVICE inline void cell_range(const GridView& g, const BoxLanesView& b, std::uint32_t i,
                                       std::uint32_t first[3], std::uint32_t last[3]) {
  for (int k = 0; k < 3; ++k) {
    first[k] = slab_of(g.planes[k], g.dims[k] - 1, b.lo[k][i]);
    last[k] = slab_of(g.planes[k], g.dims[k] - 1, b.hi[k][i]);
  }
}

// References of box i: the cells of its range, or 0 when it is large.
HBP_HOST_DEVICE inline std::uint32_t reference_count(const GridView& g, const BoxLanesView& b, std::uint32_t i) {
  std::uint32_t first[3], last[3];
  cell_range(g, b, i, first, last);
  std::uint64_t cells = 1;
  for (int k = 0; k < 3; ++k) cells *= std::uint64_t{last[k] - first[k] + 1};
  return cells > kMaxRefsPerBox ? 0u : static_cast<std::uint32_t>(cells);
}

HBP_HOST_DEVICE inline std::uint32_t cell_id(const GridView& g, std::uint32_t x, std::uint32_t y, std::uint32_t z) {
  return (z * g.dims[1] + y) * g.dims[0] + x;
}

// The region of cell `id`: its planes, infinite at the grid's outer faces.
HBP_HOST_DEVICE inline CellRegion cell_region(const GridView& g, std::uint32_t id) {
  const float inf = __builtin_huge_valf();
  std::uint32_t c[3];
  c[0] = id % g.dims[0];
  c[1] = (id / g.dims[0]) % g.dims[1];
  c[2] = id / (g.dims[0] * g.dims[1]);
  CellRegion r{};
  for (int k = 0; k < 3; ++k) {
    r.lo[k] = c[k] == 0 ? -inf : g.planes[k][c[k] - 1];
    r.hi[k] = c[k] + 1 == g.dims[k] ? inf : g.planes[k][c[k]];
  }
  return r;
}

// A float's bits mapped so that unsigned order is float order (-0 before +0;
// no NaN reaches here: the frame validates its boxes first).
HBP_HOST_DEVICE inline std::uint32_t ordered_bits(float f) {
  std::uint32_t u;
  __builtin_memcpy(&u, &f, sizeof u);
  return (u & 0x80000000u) ? ~u : (u | 0x80000000u);
}

// A reference's sort key is its cell id above position_bits bits of where
// its box's min x lies in the cell's x slab, key_bits in all (at most 32).
// The sweep needs its cell's boxes ordered by min x only up to a monotone
// map (cell_row), and a quantised position is one: half the key of (cell,
// exact min x), so the sort moves half the bytes. The key is as short as a
// whole number of bytes allows with at least kMinPositionBits of position
// (the device's radix sort takes a pass per byte): a coarser position only
// ties more boxes, which the sweep then tests on x itself.
inline constexpr int kMinPositionBits = 6;
HBP_HOST_DEVICE inline int cell_id_bits(std::uint32_t cells) {
  int bits = 1;
  while ((std::uint64_t{1} << bits) < cells) ++bits;
  return bits;
}
HBP_HOST_DEVICE inline int key_bits(std::uint32_t cells) {
  const int bytes = (cell_id_bits(cells) + kMinPositionBits + 7) / 8;
  return bytes >= 4 ? 32 : 8 * bytes;
}
HBP_HOST_DEVICE inline int position_bits(std::uint32_t cells) { return key_bits(cells) - cell_id_bits(cells); }

// floor((x - lo) / (hi - lo) * 2^bits), clamped to [0, 2^bits - 1] (0 for
// an empty or unbounded slab): non-decreasing in x, as each IEEE operation
// is, and computed by the same operations on every launcher.
HBP_HOST_DEVICE inline std::uint32_t slab_position(float x, float lo, float hi, int bits) {
  const std::uint32_t top = (bits >= 32 ? 0u : (1u << bits)) - 1u;
  const float width = hi - lo;
  if (!(width > 0.0f)) return 0;
  const float t = (x - lo) / width * static_cast<float>(std::uint64_t{1} << bits);
  if (!(t > 0.0f)) return 0;  // before the slab (a box reaching in from an earlier cell), or unbounded
  return t >= static_cast<float>(top) ? top : static_cast<std::uint32_t>(t);
}

// The finite x slab of column cx: its planes, the planned bounds outside.
HBP_HOST_DEVICE inline void x_slab(const GridView& g, std::uint32_t cx, float& lo, float& hi) {
  lo = cx == 0 ? g.x_lo : g.planes[0][cx - 1];
  hi = cx + 1 == g.dims[0] ? g.x_hi : g.planes[0][cx];
}

// Writes box i's sort keys and ids from `slot` on, in cell-id order.
template <class Key>
HBP_HOST_DEVICE inline void emit_references(const GridView& g, const BoxLanesView& b, std::uint32_t i, int bits,
                                            Key* keys, std::uint32_t* ids, std::uint64_t slot) {
  std::uint32_t first[3], last[3];
  cell_range(g, b, i, first, last);
  const float x = b.lo[0][i];
  for (std::uint32_t z = first[2]; z <= last[2]; ++z)
    for (std::uint32_t y = first[1]; y <= last[1]; ++y)
      for (std::uint32_t cx = first[0]; cx <= last[0]; ++cx) {
        float lo, hi;
        x_slab(g, cx, lo, hi);
        keys[slot] = static_cast<Key>((cell_id(g, cx, y, z) << bits) | slab_position(x, lo, hi, bits));
        ids[slot] = i;
        ++slot;
      }
}

// The accelerator's row on the frame's cells: reference r against the
// references after it in its cell [r + 1, end), in key order. Positions
// are a monotone map of min x, so once a reference's position passes that
// of r's max x every later one starts past it too: the sweep stops there.
// Before that, the x overlap is tested with the other axes (equal
// positions do not order min x). A pair is kept when the boxes overlap
// (closed intervals) and the cell's region owns it (dedup::owns). emit(k,
// a, b) receives the row's k-th pair (object ids, not canonical); returns
// the row's pair count.
template <class Emit>
HBP_HOST_DEVICE inline std::uint32_t cell_row(const CellLanes& s, std::uint32_t r, std::uint32_t end,
                                              const CellRegion& region, std::uint32_t stop, Emit&& emit) {
  const float ax0 = s.lo[0][r], ax1 = s.hi[0][r];
  const float ay0 = s.lo[1][r], ay1 = s.hi[1][r];
  const float az0 = s.lo[2][r], az1 = s.hi[2][r];
  std::uint32_t count = 0;
  for (std::uint32_t j = r + 1; j < end; ++j) {
    if (s.position[j] > stop) break;
    const float bx0 = s.lo[0][j], by0 = s.lo[1][j], bz0 = s.lo[2][j];
    const bool overlap = (ax1 >= bx0) & (ax0 <= s.hi[0][j]) & (ay1 >= by0) & (ay0 <= s.hi[1][j]) & (az1 >= bz0) &
                         (az0 <= s.hi[2][j]);
    if (!overlap || !dedup::owns(region, ax0, ay0, az0, bx0, by0, bz0)) continue;
    emit(count, s.id[r], s.id[j]);
    ++count;
  }
  return count;
}

// cell_row's stop for row r of a cell in x column cx: the position of r's max x.
HBP_HOST_DEVICE inline std::uint32_t row_stop(const GridView& g, std::uint32_t cell, float max_x, int bits) {
  float lo, hi;
  x_slab(g, cell % g.dims[0], lo, hi);
  return slab_position(max_x, lo, hi, bits);
}

// Row r of the sweep with a thread per reference, over the frame's sorted
// keys in s.position (cell id above `bits` bits of position): its cell from
// its own key, and one stop key (its cell, the position of its max x) that
// also ends the row where the next cell begins, since every later cell's
// keys are larger. So a row needs no cell table: refs is the end of all
// references. Returns cell_row's count, emit as there.
template <class Emit>
HBP_HOST_DEVICE inline std::uint32_t reference_row(const GridView& g, const CellLanes& s, int bits, std::uint32_t r,
                                                   std::uint32_t refs, Emit&& emit) {
  const std::uint32_t cell = s.position[r] >> bits;
  const std::uint32_t stop = (cell << bits) | row_stop(g, cell, s.hi[0][r], bits);
  return cell_row(s, r, refs, cell_region(g, cell), stop, static_cast<Emit&&>(emit));
}

// The sweep of one lane (the accelerator's row): reference r against the
// references after it in its cell [r + 1, end), sorted by min x, until one
// starts past r's max x. A pair is kept when the boxes overlap (closed
// intervals; x already holds by the order) and the cell's region owns it
// (dedup::owns_sorted_x: the later box's min x is the larger). emit(k, a, b)
// receives the row's k-th pair (object ids, not canonical). Returns the
// row's pair count.
template <class Emit>
HBP_HOST_DEVICE inline std::uint32_t sweep_row(const SortedLanes& s, std::uint32_t r, std::uint32_t end,
                                               const CellRegion& region, Emit&& emit) {
  const float ax1 = s.hi[0][r];
  const float ay0 = s.lo[1][r], ay1 = s.hi[1][r];
  const float az0 = s.lo[2][r], az1 = s.hi[2][r];
  std::uint32_t count = 0;
  for (std::uint32_t j = r + 1; j < end; ++j) {
    const float bx0 = s.lo[0][j];
    if (bx0 > ax1) break;
    const float by0 = s.lo[1][j], bz0 = s.lo[2][j];
    const bool overlap = (ay1 >= by0) & (ay0 <= s.hi[1][j]) & (az1 >= bz0) & (az0 <= s.hi[2][j]);
    if (!overlap || !dedup::owns_sorted_x(region, ay0, az0, bx0, by0, bz0)) continue;
    emit(count, s.id[r], s.id[j]);
    ++count;
  }
  return count;
}

// The large pass: large box l against the boxes [j0, j1) by index. A small
// partner is never in a cell with l, so l reports it; a large partner j is
// reported by the smaller of the two ids only. emit as for sweep_row.
template <class Flag, class Emit>
HBP_HOST_DEVICE inline std::uint32_t large_row(const BoxLanesView& b, const Flag* is_large, std::uint32_t l,
                                               std::uint32_t j0, std::uint32_t j1, Emit&& emit) {
  const float x0 = b.lo[0][l], x1 = b.hi[0][l], y0 = b.lo[1][l], y1 = b.hi[1][l];
  const float z0 = b.lo[2][l], z1 = b.hi[2][l];
  std::uint32_t count = 0;
  for (std::uint32_t j = j0; j < j1; ++j) {
    if (j == l || (is_large[j] && j < l)) continue;
    const bool overlap = (x1 >= b.lo[0][j]) & (x0 <= b.hi[0][j]) & (y1 >= b.lo[1][j]) & (y0 <= b.hi[1][j]) &
                         (z1 >= b.lo[2][j]) & (z0 <= b.hi[2][j]);
    if (!overlap) continue;
    emit(count, l, j);
    ++count;
  }
  return count;
}

// The large pass splits each large box's partners into chunks of this many
// indices (one count slot per chunk), at least kLargeChunk, and more when
// there are many large boxes, so the count array stays under kMaxLargeSlots.
inline constexpr std::uint32_t kLargeChunk = 1024;
inline constexpr std::uint64_t kMaxLargeSlots = std::uint64_t{1} << 22;
HBP_HOST_DEVICE inline std::uint32_t large_chunk(std::uint32_t n, std::uint32_t large) {
  const std::uint64_t need = (std::uint64_t{n} * large + kMaxLargeSlots - 1) / kMaxLargeSlots;
  return need > kLargeChunk ? static_cast<std::uint32_t>(need) : kLargeChunk;
}

}  // namespace hbp::cuda

namespace hbp::cuda {

// What is wrong with box i by the library's box screen
// (geometry::interval_fails): 0 nothing, else on the first failing axis 1 +
// axis for a NaN/Inf coordinate, 4 + axis for min > max. The frame rejects
// such boxes as the CPU path does, before any cell is chosen.
HBP_HOST_DEVICE inline std::uint32_t box_defect(const BoxLanesView& b, std::uint32_t i) {
  for (int k = 0; k < 3; ++k) {
    const float lo = b.lo[k][i], hi = b.hi[k][i];
    if (!geometry::interval_fails(lo, hi)) continue;
    const bool finite = lo - lo == 0.0f && hi - hi == 0.0f;  // x - x is NaN for NaN or Inf
    return (finite ? 4u : 1u) + static_cast<std::uint32_t>(k);
  }
  return 0;
}

}  // namespace hbp::cuda
