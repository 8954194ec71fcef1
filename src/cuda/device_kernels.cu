// SPDX-License-Identifier: MIT
#include "cuda/device_kernels.cuh"

#include <cub/block/block_scan.cuh>

#include "cuda/device_primitives.cuh"
#include "cuda/device_support.cuh"
#include "hbp/cuda/frame_broadphase.hpp"

namespace hbp::cuda {
namespace {

constexpr unsigned kThreads = 256;

unsigned blocks_for(std::uint64_t n) {
  const std::uint64_t b = (n + kThreads - 1) / kThreads;
  return static_cast<unsigned>(b < 1 ? 1 : (b > 65535u * 16 ? 65535u * 16 : b));
}

__device__ std::uint32_t warp_min(std::uint32_t v) {
  for (int d = 16; d > 0; d /= 2) v = min(v, __shfl_down_sync(0xffffffffu, v, d));
  return v;
}
__device__ std::uint32_t warp_max(std::uint32_t v) {
  for (int d = 16; d > 0; d /= 2) v = max(v, __shfl_down_sync(0xffffffffu, v, d));
  return v;
}

// Grid-stride; each thread folds its boxes, each warp its threads, each
// block its warps, and the block folds into acc with atomics (min/max and
// counts commute: the result is exact and independent of order).
__global__ void bounds_kernel(BoxLanesView b, std::uint32_t n, std::uint32_t* acc, float* packed) {
  __shared__ std::uint32_t extents[3 * kExtentBins];
  for (std::uint32_t t = threadIdx.x; t < 3 * kExtentBins; t += blockDim.x) extents[t] = 0;
  __syncthreads();
  std::uint32_t lo[3] = {~0u, ~0u, ~0u}, hi[3] = {0, 0, 0}, bad = n;
  // Warp-uniform steps (the stride is a multiple of 32), so a histogram bin
  // takes one atomic per warp and distinct bin: in most scenes nearly every
  // box has the same extents, and one atomic per box would serialise on it.
  const std::uint32_t lane = threadIdx.x & 31u;
  for (std::uint32_t w = blockIdx.x * blockDim.x + (threadIdx.x & ~31u); w < n; w += gridDim.x * blockDim.x) {
    const std::uint32_t i = w + lane;
    const bool valid = i < n && !box_defect(b, i);
    if (i < n && !valid) bad = min(bad, i);
    if (packed && i < n) {
      float2* box = reinterpret_cast<float2*>(packed + std::size_t{6} * i);
      box[0] = make_float2(b.lo[0][i], b.lo[1][i]);
      box[1] = make_float2(b.lo[2][i], b.hi[0][i]);
      box[2] = make_float2(b.hi[1][i], b.hi[2][i]);
    }
    for (int k = 0; k < 3; ++k) {
      std::uint32_t bin = kExtentBins;  // none
      if (valid) {
        lo[k] = min(lo[k], ordered_bits(b.lo[k][i]));
        hi[k] = max(hi[k], ordered_bits(b.hi[k][i]));
        bin = extent_bin(b.lo[k][i], b.hi[k][i]);
      }
      const unsigned same = __match_any_sync(0xffffffffu, bin);
      if (bin != kExtentBins && lane == static_cast<std::uint32_t>(__ffs(same) - 1))
        atomicAdd(extents + k * kExtentBins + bin, static_cast<std::uint32_t>(__popc(same)));
    }
  }
  // Warps fold into the block's words, the block into acc: one global
  // atomic per block and word (per warp, they serialise on seven addresses).
  __shared__ std::uint32_t folded[7];
  if (threadIdx.x < 7) folded[threadIdx.x] = threadIdx.x < 3 ? ~0u : threadIdx.x < 6 ? 0u : n;
  __syncthreads();
  for (int k = 0; k < 3; ++k) {
    lo[k] = warp_min(lo[k]);
    hi[k] = warp_max(hi[k]);
  }
  bad = warp_min(bad);
  if (lane == 0) {
    for (int k = 0; k < 3; ++k) {
      atomicMin(folded + k, lo[k]);
      atomicMax(folded + 3 + k, hi[k]);
    }
    atomicMin(folded + 6, bad);
  }
  __syncthreads();
  if (threadIdx.x < 3) atomicMin(acc + threadIdx.x, folded[threadIdx.x]);
  else if (threadIdx.x < 6) atomicMax(acc + threadIdx.x, folded[threadIdx.x]);
  else if (threadIdx.x == 6 && folded[6] < n) atomicMin(acc + 6, folded[6]);
  for (std::uint32_t t = threadIdx.x; t < 3 * kExtentBins; t += blockDim.x)
    if (extents[t]) atomicAdd(acc + kBoundsExtents + t, extents[t]);
}

__global__ void rows_to_lanes_kernel(const float* rows, std::int64_t row_stride, std::int64_t column_stride,
                                     std::uint32_t n, float* lanes) {
  const std::uint32_t i = blockIdx.x * blockDim.x + threadIdx.x;
  if (i >= n) return;
  for (int l = 0; l < 6; ++l) lanes[static_cast<std::size_t>(l) * n + i] = rows[i * row_stride + l * column_stride];
}

// count[i]: box i's references in the low word, 1 in the high word when it
// is large, so one scan gives both offsets (references stay below 2^31:
// kMaxRefsPerBox per box of at most kMaxFrameObjects, no carry).
__global__ void reference_count_kernel(GridView g, BoxLanesView b, std::uint32_t n, std::uint64_t* count,
                                       std::uint32_t* is_large) {
  const std::uint32_t i = blockIdx.x * blockDim.x + threadIdx.x;
  if (i >= n) return;
  const std::uint32_t c = reference_count(g, b, i);
  count[i] = c == 0 ? std::uint64_t{1} << 32 : c;
  is_large[i] = c == 0;
}

__global__ void emit_kernel(GridView g, BoxLanesView b, std::uint32_t n, int bits, const std::uint32_t* is_large,
                            const std::uint64_t* offset, std::uint32_t* keys, std::uint32_t* ids,
                            std::uint32_t* large_list) {
  const std::uint32_t i = blockIdx.x * blockDim.x + threadIdx.x;
  if (i >= n) return;
  const std::uint64_t o = offset[i];
  if (is_large[i])
    large_list[o >> 32] = i;
  else
    emit_references(g, b, i, bits, keys, ids, o & 0xffffffffu);
}

__global__ void gather_kernel(BoxLanesView b, const std::uint64_t* keys, const std::uint32_t* ids,
                              std::uint32_t refs, float* lanes, std::uint32_t* head) {
  const std::uint32_t r = blockIdx.x * blockDim.x + threadIdx.x;
  if (r >= refs) return;
  const std::uint32_t i = ids[r];
  for (int k = 0; k < 3; ++k) {
    lanes[static_cast<std::size_t>(k) * refs + r] = b.lo[k][i];
    lanes[static_cast<std::size_t>(3 + k) * refs + r] = b.hi[k][i];
  }
  head[r] = r == 0 || (keys[r] >> 32) != (keys[r - 1] >> 32);
}

// Box `id` of `packed` into slot r of the six sorted lanes (refs each).
// One box's six floats are 24 adjacent bytes of `packed`: a random gather
// touches one or two sectors, where the six lanes would take six.
__device__ void gather_box(const float* packed, std::uint32_t id, std::uint32_t r, std::uint32_t refs, float* lanes) {
  const float2* box = reinterpret_cast<const float2*>(packed + std::size_t{6} * id);
  const float2 v0 = box[0], v1 = box[1], v2 = box[2];
  const float v[6] = {v0.x, v0.y, v1.x, v1.y, v2.x, v2.y};
  for (int l = 0; l < 6; ++l) lanes[static_cast<std::size_t>(l) * refs + r] = v[l];
}

// The frame's gather: sorted lanes, positions (the keys' low bits), and
// head[r] = 1 where a cell starts.
__global__ void gather_cells_kernel(const float* packed, const std::uint32_t* keys, const std::uint32_t* ids,
                                    std::uint32_t refs, int bits, float* lanes, std::uint32_t* positions,
                                    std::uint32_t* head) {
  const std::uint32_t r = blockIdx.x * blockDim.x + threadIdx.x;
  if (r >= refs) return;
  gather_box(packed, ids[r], r, refs, lanes);
  const std::uint32_t key = keys[r];
  positions[r] = key & static_cast<std::uint32_t>((std::uint64_t{1} << bits) - 1);
  head[r] = r == 0 || (key >> bits) != (keys[r - 1] >> bits);
}

__global__ void cells_kernel(GridView g, const std::uint32_t* keys, int bits, const std::uint32_t* head_scan,
                             std::uint32_t refs, std::uint32_t* cell_begin, std::uint32_t* cell_ids,
                             CellRegion* regions, std::uint32_t* cells) {
  const std::uint32_t r = blockIdx.x * blockDim.x + threadIdx.x;
  if (r >= refs) return;
  if (r == 0 || head_scan[r] != head_scan[r - 1]) {
    const std::uint32_t c = head_scan[r] - 1;
    const std::uint32_t id = keys[r] >> bits;
    cell_begin[c] = r;
    cell_ids[c] = id;
    regions[c] = cell_region(g, id);
  }
  if (r + 1 == refs) {
    cell_begin[head_scan[r]] = refs;
    *cells = head_scan[r];
  }
}

__global__ void gather_lanes_kernel(const float* packed, const std::uint32_t* keys, const std::uint32_t* ids,
                                    std::uint32_t refs, int bits, float* lanes, std::uint32_t* cells) {
  const std::uint32_t r = blockIdx.x * blockDim.x + threadIdx.x;
  const bool head = r < refs && (r == 0 || (keys[r] >> bits) != (keys[r - 1] >> bits));
  const unsigned heads = __ballot_sync(0xffffffffu, head);
  if ((threadIdx.x & 31u) == 0 && heads) atomicAdd(cells, static_cast<std::uint32_t>(__popc(heads)));
  if (r >= refs) return;
  gather_box(packed, ids[r], r, refs, lanes);
}

// The rows with a thread per reference (CellSweep::PerReference): row r of
// its cell read straight from the sorted lanes. Neighbouring threads sweep
// neighbouring rows, so their candidates come from the same cache lines, and
// no block is tied to a cell: a dense cell's rows spread over every SM and a
// small cell leaves no lane idle. s.position holds the whole keys
// (reference_row).
// Counting (no `out`), a row also keeps its first kInlinePairs pairs in
// kept[r]; filling, a row that had no more copies them instead of sweeping
// again (most rows of a sparse scene).
__global__ void reference_rows_kernel(GridView g, CellLanes s, int bits, std::uint32_t refs, RowPairs* kept,
                                      std::uint64_t* counts, const std::uint64_t* offsets, std::uint32_t* out) {
  const std::uint32_t r = blockIdx.x * blockDim.x + threadIdx.x;
  if (r >= refs) return;
  uint2* row = out ? reinterpret_cast<uint2*>(out) + offsets[r] : nullptr;
  if (out) {
    const std::uint64_t count = offsets[r + 1] - offsets[r];
    if (count <= kInlinePairs) {
      for (std::uint32_t k = 0; k < count; ++k) row[k] = kept[r].pair[k];
      return;
    }
  }
  if (!out) {
    RowPairs& keep = kept[r];
    counts[r] = reference_row(g, s, bits, r, refs, [&keep](std::uint32_t k, std::uint32_t a, std::uint32_t b) {
      if (k < kInlinePairs) keep.pair[k] = a < b ? make_uint2(a, b) : make_uint2(b, a);
    });
  } else {
    reference_row(g, s, bits, r, refs, [row](std::uint32_t k, std::uint32_t a, std::uint32_t b) {
      row[k] = a < b ? make_uint2(a, b) : make_uint2(b, a);
    });
  }
}

// Sorted frames (the pair order pass gives the one list, so the list's
// own order may vary): each thread counts its row's pairs, the block sums
// them and takes its room in `out` with one atomic on `total`, and the rows
// are swept again writing, their candidates still in cache. No per-row
// count array, scan or read-back sits between counting and writing. Rows
// whose room would pass `capacity` write nothing; *total still counts
// every pair, so the caller sees the frame did not fit and runs it again
// in a larger buffer. Every thread of the block calls it.
// The block's sums are 64-bit: 256 rows of a cell of 2^28 boxes on one
// point hold more than 2^32 pairs, and a wrapped sum would undercount the
// total that decides whether the frame fits.
template <class Write>
__device__ void append_block_rows(std::uint32_t count, unsigned long long* total, std::uint64_t capacity,
                                  Write&& write) {
  using Scan = cub::BlockScan<unsigned long long, kThreads>;
  __shared__ typename Scan::TempStorage scan;
  __shared__ unsigned long long base;
  unsigned long long offset = 0, block_total = 0;
  Scan(scan).ExclusiveSum(static_cast<unsigned long long>(count), offset, block_total);
  if (threadIdx.x == 0) base = block_total ? atomicAdd(total, block_total) : 0;
  __syncthreads();
  if (count && base + offset + count <= capacity) write(base + offset);
}

__global__ void __launch_bounds__(kThreads)
    append_reference_rows_kernel(GridView g, CellLanes s, int bits, std::uint32_t refs, unsigned long long* total,
                                 std::uint64_t capacity, uint2* out) {
  const std::uint32_t r = blockIdx.x * blockDim.x + threadIdx.x;
  const std::uint32_t count =
      r < refs ? reference_row(g, s, bits, r, refs, [](std::uint32_t, std::uint32_t, std::uint32_t) {}) : 0;
  append_block_rows(count, total, capacity, [&](std::uint64_t at) {
    uint2* row = out + at;
    reference_row(g, s, bits, r, refs, [row](std::uint32_t k, std::uint32_t a, std::uint32_t b) {
      row[k] = a < b ? make_uint2(a, b) : make_uint2(b, a);
    });
  });
}

// A cell's boxes in shared memory: the accelerator's buffer memories.
template <std::uint32_t kBoxes>
struct CellBuffer {
  float lane[6][kBoxes];
  std::uint32_t id[kBoxes];
  std::uint32_t position[kBoxes];
};

// The accelerator on one cell: its boxes copied into `buffer` when they fit
// (else swept from global memory by the same body), each thread sweeping
// rows threadIdx.x, + blockDim.x, ...; counts[r] per row, or with `out` the
// pairs from offsets[r]. Every thread of the block calls it (barriers).
template <std::uint32_t kBoxes>
__device__ void sweep_cell(const GridView& g, const CellLanes& sorted, int bits, std::uint32_t begin,
                           std::uint32_t size, std::uint32_t cell_id, const CellRegion& region,
                           CellBuffer<kBoxes>& buffer, std::uint64_t* counts, const std::uint64_t* offsets,
                           std::uint32_t* out) {
  CellLanes s = sorted;
  std::uint32_t base = begin;  // row r of s is reference base + r
  if (size <= kBoxes) {
    for (std::uint32_t r = threadIdx.x; r < size; r += blockDim.x) {
      for (int k = 0; k < 3; ++k) {
        buffer.lane[k][r] = sorted.lo[k][begin + r];
        buffer.lane[3 + k][r] = sorted.hi[k][begin + r];
      }
      buffer.id[r] = sorted.id[begin + r];
      buffer.position[r] = sorted.position[begin + r];
    }
    __syncthreads();
    s = CellLanes{{buffer.lane[0], buffer.lane[1], buffer.lane[2]},
                  {buffer.lane[3], buffer.lane[4], buffer.lane[5]},
                  buffer.id,
                  buffer.position};
    base = 0;
  }
  for (std::uint32_t r = threadIdx.x; r < size; r += blockDim.x) {
    const std::uint32_t stop = row_stop(g, cell_id, s.hi[0][base + r], bits);
    if (!out) {
      counts[begin + r] =
          cell_row(s, base + r, base + size, region, stop, [](std::uint32_t, std::uint32_t, std::uint32_t) {});
    } else {
      uint2* row = reinterpret_cast<uint2*>(out) + offsets[begin + r];
      cell_row(s, base + r, base + size, region, stop, [row](std::uint32_t k, std::uint32_t a, std::uint32_t b) {
        row[k] = a < b ? make_uint2(a, b) : make_uint2(b, a);
      });
    }
  }
}

// Cells of up to kBlockBoxes boxes: a block of kLanes threads each; a larger
// cell is put on the big-cell list for big_cell_rows_kernel (which block
// takes which big cell changes no count and no pair's place: offsets are
// per row).
__global__ void __launch_bounds__(kLanes) cell_rows_kernel(GridView g, CellLanes sorted, int bits,
                                                           const std::uint32_t* cell_begin,
                                                           const std::uint32_t* cell_ids, const CellRegion* regions,
                                                           const std::uint32_t* cells, std::uint32_t* big_cells,
                                                           std::uint64_t* counts, const std::uint64_t* offsets,
                                                           std::uint32_t* out) {
  __shared__ CellBuffer<kBlockBoxes> buffer;
  const std::uint32_t c = blockIdx.x;
  if (c >= *cells) return;
  const std::uint32_t begin = cell_begin[c], size = cell_begin[c + 1] - begin;
  if (size > kBlockBoxes) {
    if (threadIdx.x == 0) big_cells[1 + atomicAdd(big_cells, 1u)] = c;
    return;
  }
  sweep_cell(g, sorted, bits, begin, size, cell_ids[c], regions[c], buffer, counts, offsets, out);
}

// The big cells (dense regions of a clustered scene), listed by
// cell_rows_kernel (big_cells[0] of them from big_cells[1]): a fixed grid of
// kBigLanes-thread blocks with a larger buffer, each taking list entries
// blockIdx.x, + gridDim.x, ...
__global__ void __launch_bounds__(kBigLanes)
    big_cell_rows_kernel(GridView g, CellLanes sorted, int bits, const std::uint32_t* cell_begin,
                         const std::uint32_t* cell_ids, const CellRegion* regions, const std::uint32_t* big_cells,
                         std::uint64_t* counts, const std::uint64_t* offsets, std::uint32_t* out) {
  __shared__ CellBuffer<kBigCellBoxes> buffer;
  const std::uint32_t listed = big_cells[0];
  for (std::uint32_t q = blockIdx.x; q < listed; q += gridDim.x) {
    const std::uint32_t c = big_cells[1 + q];
    const std::uint32_t begin = cell_begin[c], size = cell_begin[c + 1] - begin;
    sweep_cell(g, sorted, bits, begin, size, cell_ids[c], regions[c], buffer, counts, offsets, out);
    __syncthreads();  // the buffer is refilled for the next cell
  }
}

// One cell sorted by exact min x (a cell of the "cuda" cell engine) swept
// by the calling block of kBigLanes threads with sweep_row, its boxes in
// shared memory when they fit.
__device__ void block_sorted_cell_rows(const SortedLanes& sorted, std::uint32_t size, const CellRegion& region,
                                       std::uint64_t* counts, const std::uint64_t* offsets, std::uint32_t* out) {
  __shared__ float lane[6][kBigCellBoxes];
  __shared__ std::uint32_t id[kBigCellBoxes];
  SortedLanes s = sorted;
  if (size <= kBigCellBoxes) {
    for (std::uint32_t r = threadIdx.x; r < size; r += blockDim.x) {
      for (int k = 0; k < 3; ++k) {
        lane[k][r] = sorted.lo[k][r];
        lane[3 + k][r] = sorted.hi[k][r];
      }
      id[r] = sorted.id[r];
    }
    __syncthreads();
    s = SortedLanes{{lane[0], lane[1], lane[2]}, {lane[3], lane[4], lane[5]}, id};
  }
  for (std::uint32_t r = threadIdx.x; r < size; r += blockDim.x) {
    if (!out) {
      counts[r] = sweep_row(s, r, size, region, [](std::uint32_t, std::uint32_t, std::uint32_t) {});
    } else {
      uint2* row = reinterpret_cast<uint2*>(out) + offsets[r];
      sweep_row(s, r, size, region, [row](std::uint32_t k, std::uint32_t a, std::uint32_t b) {
        row[k] = a < b ? make_uint2(a, b) : make_uint2(b, a);
      });
    }
  }
}

__global__ void __launch_bounds__(kBigLanes)
    sorted_cell_rows_kernel(SortedLanes sorted, std::uint32_t size, CellRegion region, std::uint64_t* counts,
                            const std::uint64_t* offsets, std::uint32_t* out) {
  block_sorted_cell_rows(sorted, size, region, counts, offsets, out);
}

// Block k sweeps cell k of a batch: boxes [starts[k], starts[k + 1]) of the
// batch's lanes, ids local to the cell (`iota`: 0, 1, 2, ...); its rows'
// counts and offsets at the same positions.
__global__ void __launch_bounds__(kBigLanes)
    sorted_batch_rows_kernel(SortedLanes batch, const std::uint32_t* starts, const CellRegion* regions,
                             std::uint64_t* counts, const std::uint64_t* offsets, std::uint32_t* out) {
  const std::uint32_t first = starts[blockIdx.x], size = starts[blockIdx.x + 1] - first;
  const SortedLanes cell{{batch.lo[0] + first, batch.lo[1] + first, batch.lo[2] + first},
                         {batch.hi[0] + first, batch.hi[1] + first, batch.hi[2] + first},
                         batch.id};
  block_sorted_cell_rows(cell, size, regions[blockIdx.x], counts + first, offsets ? offsets + first : nullptr, out);
}

__global__ void large_rows_kernel(BoxLanesView b, std::uint32_t n, const std::uint32_t* is_large,
                                  const std::uint32_t* large_list, std::uint32_t large, std::uint32_t chunk,
                                  std::uint32_t chunks, std::uint64_t* counts, const std::uint64_t* offsets,
                                  std::uint32_t* out) {
  const std::uint64_t q = std::uint64_t{blockIdx.x} * blockDim.x + threadIdx.x;
  if (q >= std::uint64_t{large} * chunks) return;
  const std::uint32_t l = large_list[q / chunks];
  const std::uint32_t j0 = static_cast<std::uint32_t>(q % chunks) * chunk;
  const std::uint32_t j1 = n - j0 < chunk ? n : j0 + chunk;
  if (!out) {
    counts[q] = large_row(b, is_large, l, j0, j1, [](std::uint32_t, std::uint32_t, std::uint32_t) {});
  } else {
    std::uint32_t* row = out + 2 * offsets[q];
    large_row(b, is_large, l, j0, j1, [row](std::uint32_t k, std::uint32_t a, std::uint32_t bb) {
      row[2 * k] = a < bb ? a : bb;
      row[2 * k + 1] = a < bb ? bb : a;
    });
  }
}

__global__ void __launch_bounds__(kThreads)
    append_large_rows_kernel(BoxLanesView b, std::uint32_t n, const std::uint32_t* is_large,
                             const std::uint32_t* large_list, std::uint32_t large, std::uint32_t chunk,
                             std::uint32_t chunks, unsigned long long* total, std::uint64_t capacity, uint2* out) {
  const std::uint64_t q = std::uint64_t{blockIdx.x} * blockDim.x + threadIdx.x;
  std::uint32_t l = 0, j0 = 0, j1 = 0, count = 0;
  if (q < std::uint64_t{large} * chunks) {
    l = large_list[q / chunks];
    j0 = static_cast<std::uint32_t>(q % chunks) * chunk;
    j1 = n - j0 < chunk ? n : j0 + chunk;
    count = large_row(b, is_large, l, j0, j1, [](std::uint32_t, std::uint32_t, std::uint32_t) {});
  }
  append_block_rows(count, total, capacity, [&](std::uint64_t at) {
    uint2* row = out + at;
    large_row(b, is_large, l, j0, j1, [row](std::uint32_t k, std::uint32_t a, std::uint32_t bb) {
      row[k] = a < bb ? make_uint2(a, bb) : make_uint2(bb, a);
    });
  });
}

__global__ void pack_kernel(const std::uint32_t* pairs, std::uint64_t count, int id_bits, std::uint64_t* keys) {
  const std::uint64_t p = std::uint64_t{blockIdx.x} * blockDim.x + threadIdx.x;
  if (p < count) {
    const uint2 pair = reinterpret_cast<const uint2*>(pairs)[p];
    keys[p] = (std::uint64_t{pair.x} << id_bits) | pair.y;
  }
}

__global__ void unpack_kernel(const std::uint64_t* keys, std::uint64_t count, int id_bits, std::uint32_t* pairs) {
  const std::uint64_t p = std::uint64_t{blockIdx.x} * blockDim.x + threadIdx.x;
  if (p < count) {
    const std::uint64_t key = keys[p];
    reinterpret_cast<uint2*>(pairs)[p] =
        make_uint2(static_cast<std::uint32_t>(key >> id_bits), static_cast<std::uint32_t>(key & ((1ull << id_bits) - 1)));
  }
}

// PairOrder::Buckets. Pairs of one a come in runs (a row's pairs share
// its own id when it is the smaller), so the lanes holding the same a take
// one atomic between them: a histogram entry per object, then a scatter
// that counts each bucket down from its end.
__global__ void bucket_count_kernel(const uint2* pairs, std::uint64_t count, unsigned long long* per_object) {
  const std::uint64_t p = std::uint64_t{blockIdx.x} * blockDim.x + threadIdx.x;
  const unsigned active = __ballot_sync(0xffffffffu, p < count);
  if (p >= count) return;
  const std::uint32_t a = pairs[p].x;
  const unsigned same = __match_any_sync(active, a);
  if ((threadIdx.x & 31u) == static_cast<unsigned>(__ffs(same) - 1))
    atomicAdd(per_object + a, static_cast<unsigned long long>(__popc(same)));
}

// Each pair to its bucket as the key b << 32 | a: its bytes are the pair's
// (a, b), and within a bucket (one a) key order is b's order.
__global__ void bucket_scatter_kernel(const uint2* pairs, std::uint64_t count, const std::uint64_t* starts,
                                      unsigned long long* left, std::uint64_t* keys) {
  const std::uint64_t p = std::uint64_t{blockIdx.x} * blockDim.x + threadIdx.x;
  const unsigned active = __ballot_sync(0xffffffffu, p < count);
  if (p >= count) return;
  const uint2 pair = pairs[p];
  const unsigned same = __match_any_sync(active, pair.x);
  const int leader = __ffs(same) - 1;
  const unsigned lane = threadIdx.x & 31u;
  unsigned long long end = 0;
  if (static_cast<int>(lane) == leader)
    end = atomicAdd(left + pair.x, static_cast<unsigned long long>(-static_cast<long long>(__popc(same))));
  end = __shfl_sync(same, end, leader);
  const std::uint64_t rank = static_cast<std::uint64_t>(__popc(same & ((1u << lane) - 1u)));
  keys[starts[pair.x] + end - 1 - rank] = (std::uint64_t{pair.y} << 32) | pair.x;
}

unsigned grid_for(std::uint64_t n) { return static_cast<unsigned>((n + kThreads - 1) / kThreads); }

__global__ void centre_sums_kernel(BoxLanesView b, std::uint32_t n, double* sums) {
  double acc[6] = {0, 0, 0, 0, 0, 0};
  for (std::uint32_t i = blockIdx.x * blockDim.x + threadIdx.x; i < n; i += gridDim.x * blockDim.x)
    for (int k = 0; k < 3; ++k) {
      const double c = static_cast<double>(b.lo[k][i]) + b.hi[k][i];
      acc[k] += c;
      acc[3 + k] += c * c;
    }
  for (int v = 0; v < 6; ++v) {
    for (int d = 16; d > 0; d /= 2) acc[v] += __shfl_down_sync(0xffffffffu, acc[v], d);
    if ((threadIdx.x & 31u) == 0) atomicAdd(sums + v, acc[v]);
  }
}

__global__ void axis_keys_kernel(BoxLanesView b, std::uint32_t n, std::uint64_t* keys, std::uint32_t* ids) {
  const std::uint32_t i = blockIdx.x * blockDim.x + threadIdx.x;
  if (i >= n) return;
  keys[i] = ordered_bits(b.lo[0][i]);
  ids[i] = i;
}

__global__ void scene_rows_kernel(SortedLanes sorted, std::uint32_t n, std::uint64_t* counts,
                                  const std::uint64_t* offsets, std::uint32_t* out) {
  const std::uint32_t r = blockIdx.x * blockDim.x + threadIdx.x;
  if (r >= n) return;
  const CellRegion everything{{-__builtin_huge_valf(), -__builtin_huge_valf(), -__builtin_huge_valf()},
                              {__builtin_huge_valf(), __builtin_huge_valf(), __builtin_huge_valf()}};
  if (!out) {
    counts[r] = sweep_row(sorted, r, n, everything, [](std::uint32_t, std::uint32_t, std::uint32_t) {});
  } else {
    std::uint32_t* row = out + 2 * offsets[r];
    sweep_row(sorted, r, n, everything, [row](std::uint32_t k, std::uint32_t a, std::uint32_t bb) {
      row[2 * k] = a < bb ? a : bb;
      row[2 * k + 1] = a < bb ? bb : a;
    });
  }
}

}  // namespace

void launch_bounds(const BoxLanesView& b, std::uint32_t n, std::uint32_t* acc, cudaStream_t s, float* packed) {
  bounds_kernel<<<blocks_for(n) < 1024 ? blocks_for(n) : 1024, kThreads, 0, s>>>(b, n, acc, packed);
  check_cuda(cudaGetLastError(), "bounds kernel");
}

void launch_rows_to_lanes(const float* rows, std::int64_t row_stride, std::int64_t column_stride, std::uint32_t n,
                          float* lanes, cudaStream_t s) {
  if (!n) return;
  rows_to_lanes_kernel<<<grid_for(n), kThreads, 0, s>>>(rows, row_stride, column_stride, n, lanes);
  check_cuda(cudaGetLastError(), "rows to lanes kernel");
}

void launch_reference_count(const GridView& g, const BoxLanesView& b, std::uint32_t n, std::uint64_t* count,
                            std::uint32_t* is_large, cudaStream_t s) {
  if (!n) return;
  reference_count_kernel<<<grid_for(n), kThreads, 0, s>>>(g, b, n, count, is_large);
  check_cuda(cudaGetLastError(), "reference count kernel");
}

void launch_emit(const GridView& g, const BoxLanesView& b, std::uint32_t n, int bits, const std::uint32_t* is_large,
                 const std::uint64_t* offset, std::uint32_t* keys, std::uint32_t* ids, std::uint32_t* large_list,
                 cudaStream_t s) {
  if (!n) return;
  emit_kernel<<<grid_for(n), kThreads, 0, s>>>(g, b, n, bits, is_large, offset, keys, ids, large_list);
  check_cuda(cudaGetLastError(), "emit kernel");
}

void launch_gather(const BoxLanesView& b, const std::uint64_t* keys, const std::uint32_t* ids, std::uint32_t refs,
                   float* lanes, std::uint32_t* head, cudaStream_t s) {
  if (!refs) return;
  gather_kernel<<<grid_for(refs), kThreads, 0, s>>>(b, keys, ids, refs, lanes, head);
  check_cuda(cudaGetLastError(), "gather kernel");
}

void launch_gather_cells(const float* packed, const std::uint32_t* keys, const std::uint32_t* ids, std::uint32_t refs,
                         int bits, float* lanes, std::uint32_t* positions, std::uint32_t* head, cudaStream_t s) {
  if (!refs) return;
  gather_cells_kernel<<<grid_for(refs), kThreads, 0, s>>>(packed, keys, ids, refs, bits, lanes, positions, head);
  check_cuda(cudaGetLastError(), "gather cells kernel");
}

void launch_gather_lanes(const float* packed, const std::uint32_t* keys, const std::uint32_t* ids, std::uint32_t refs,
                         int bits, float* lanes, std::uint32_t* cells, cudaStream_t s) {
  if (!refs) return;
  gather_lanes_kernel<<<grid_for(refs), kThreads, 0, s>>>(packed, keys, ids, refs, bits, lanes, cells);
  check_cuda(cudaGetLastError(), "gather lanes kernel");
}

void launch_cells(const GridView& g, const std::uint32_t* keys, int bits, const std::uint32_t* head_scan,
                  std::uint32_t refs, std::uint32_t* cell_begin, std::uint32_t* cell_ids, CellRegion* regions,
                  std::uint32_t* cells, cudaStream_t s) {
  if (!refs) return;
  cells_kernel<<<grid_for(refs), kThreads, 0, s>>>(g, keys, bits, head_scan, refs, cell_begin, cell_ids, regions,
                                                   cells);
  check_cuda(cudaGetLastError(), "cells kernel");
}

void launch_cell_rows(const GridView& g, const CellLanes& sorted, int bits, const std::uint32_t* cell_begin,
                      const std::uint32_t* cell_ids, const CellRegion* regions, const std::uint32_t* cells,
                      std::uint32_t blocks, std::uint32_t* big_cells, std::uint64_t* counts,
                      const std::uint64_t* offsets, std::uint32_t* out, cudaStream_t s) {
  if (!blocks) return;
  check_cuda(cudaMemsetAsync(big_cells, 0, sizeof(std::uint32_t), s), "big cells");
  cell_rows_kernel<<<blocks, kLanes, 0, s>>>(g, sorted, bits, cell_begin, cell_ids, regions, cells, big_cells, counts,
                                             offsets, out);
  check_cuda(cudaGetLastError(), "cell rows kernel");
  big_cell_rows_kernel<<<blocks < kBigCellBlocks ? blocks : kBigCellBlocks, kBigLanes, 0, s>>>(
      g, sorted, bits, cell_begin, cell_ids, regions, big_cells, counts, offsets, out);
  check_cuda(cudaGetLastError(), "big cell rows kernel");
}

void launch_reference_rows(const GridView& g, const CellLanes& sorted, int bits, std::uint32_t refs, RowPairs* kept,
                           std::uint64_t* counts, const std::uint64_t* offsets, std::uint32_t* out, cudaStream_t s) {
  if (!refs) return;
  reference_rows_kernel<<<grid_for(refs), kThreads, 0, s>>>(g, sorted, bits, refs, kept, counts, offsets, out);
  check_cuda(cudaGetLastError(), "reference rows kernel");
}

void launch_append_rows(const GridView& g, const CellLanes& sorted, int bits, std::uint32_t refs,
                        const BoxLanesView& b, std::uint32_t n, const std::uint32_t* is_large,
                        const std::uint32_t* large_list, std::uint32_t large, std::uint32_t chunk,
                        unsigned long long* total, std::uint64_t capacity, std::uint32_t* out, cudaStream_t s) {
  check_cuda(cudaMemsetAsync(total, 0, sizeof *total, s), "pair total");
  uint2* pairs = reinterpret_cast<uint2*>(out);
  if (refs) {
    append_reference_rows_kernel<<<grid_for(refs), kThreads, 0, s>>>(g, sorted, bits, refs, total, capacity, pairs);
    check_cuda(cudaGetLastError(), "append reference rows kernel");
  }
  const std::uint32_t chunks = (n + chunk - 1) / chunk;
  const std::uint64_t slots = std::uint64_t{large} * chunks;
  if (slots) {
    append_large_rows_kernel<<<grid_for(slots), kThreads, 0, s>>>(b, n, is_large, large_list, large, chunk, chunks,
                                                                  total, capacity, pairs);
    check_cuda(cudaGetLastError(), "append large rows kernel");
  }
}

void launch_sorted_cell_rows(const SortedLanes& sorted, std::uint32_t size, const CellRegion& region,
                             std::uint64_t* counts, const std::uint64_t* offsets, std::uint32_t* out, cudaStream_t s) {
  if (!size) return;
  sorted_cell_rows_kernel<<<1, kBigLanes, 0, s>>>(sorted, size, region, counts, offsets, out);
  check_cuda(cudaGetLastError(), "sorted cell rows kernel");
}

void launch_sorted_batch_rows(const SortedLanes& batch, std::uint32_t cells, const std::uint32_t* starts,
                              const CellRegion* regions, std::uint64_t* counts, const std::uint64_t* offsets,
                              std::uint32_t* out, cudaStream_t s) {
  if (!cells) return;
  sorted_batch_rows_kernel<<<cells, kBigLanes, 0, s>>>(batch, starts, regions, counts, offsets, out);
  check_cuda(cudaGetLastError(), "sorted batch rows kernel");
}

void launch_large_rows(const BoxLanesView& b, std::uint32_t n, const std::uint32_t* is_large,
                       const std::uint32_t* large_list, std::uint32_t large, std::uint32_t chunk, std::uint64_t* counts,
                       const std::uint64_t* offsets, std::uint32_t* out, cudaStream_t s) {
  const std::uint32_t chunks = (n + chunk - 1) / chunk;
  const std::uint64_t slots = std::uint64_t{large} * chunks;
  if (!slots) return;
  large_rows_kernel<<<grid_for(slots), kThreads, 0, s>>>(b, n, is_large, large_list, large, chunk, chunks, counts,
                                                         offsets, out);
  check_cuda(cudaGetLastError(), "large rows kernel");
}

void launch_centre_sums(const BoxLanesView& b, std::uint32_t n, double* sums, cudaStream_t s) {
  if (!n) return;
  centre_sums_kernel<<<blocks_for(n) < 1024 ? blocks_for(n) : 1024, kThreads, 0, s>>>(b, n, sums);
  check_cuda(cudaGetLastError(), "centre sums kernel");
}

void launch_axis_keys(const BoxLanesView& b, std::uint32_t n, std::uint64_t* keys, std::uint32_t* ids, cudaStream_t s) {
  if (!n) return;
  axis_keys_kernel<<<grid_for(n), kThreads, 0, s>>>(b, n, keys, ids);
  check_cuda(cudaGetLastError(), "axis keys kernel");
}

void launch_scene_rows(const SortedLanes& sorted, std::uint32_t n, std::uint64_t* counts, const std::uint64_t* offsets,
                       std::uint32_t* out, cudaStream_t s) {
  if (!n) return;
  scene_rows_kernel<<<grid_for(n), kThreads, 0, s>>>(sorted, n, counts, offsets, out);
  check_cuda(cudaGetLastError(), "scene rows kernel");
}

void launch_pack_pairs(const std::uint32_t* pairs, std::uint64_t count, int id_bits, std::uint64_t* keys,
                       cudaStream_t s) {
  if (!count) return;
  pack_kernel<<<grid_for(count), kThreads, 0, s>>>(pairs, count, id_bits, keys);
  check_cuda(cudaGetLastError(), "pack kernel");
}

void launch_unpack_pairs(const std::uint64_t* keys, std::uint64_t count, int id_bits, std::uint32_t* pairs,
                         cudaStream_t s) {
  if (!count) return;
  unpack_kernel<<<grid_for(count), kThreads, 0, s>>>(keys, count, id_bits, pairs);
  check_cuda(cudaGetLastError(), "unpack kernel");
}

namespace {
int id_bits_of(std::uint32_t objects) {
  int bits = 1;
  while ((std::uint64_t{1} << bits) < objects) ++bits;
  return bits;
}
}  // namespace

PairOrderBytes pair_order_bytes(PairOrder order, std::uint64_t count, std::uint32_t objects) {
  // Radix: keys and the sort's alternate. Buckets: the scattered keys, then
  // per object its count and bucket start (objects + 1 starts).
  if (order == PairOrder::Radix) return {count * 8, count * 8};
  return {count * 8, (2 * std::size_t{objects} + 1) * 8};
}

int sort_pairs_by_ab(PairOrder order, std::uint32_t* pairs, std::uint64_t count, std::uint32_t objects,
                     DeviceBuffer& keys, DeviceBuffer& scratch, DeviceBuffer& temp, cudaStream_t s) {
  if (count < 2) return 0;
  const PairOrderBytes bytes = pair_order_bytes(order, count, objects);
  int allocations = int(keys.reserve(bytes.keys)) + int(scratch.reserve(bytes.scratch));
  if (order == PairOrder::Radix) {
    const int id_bits = id_bits_of(objects);
    launch_pack_pairs(pairs, count, id_bits, keys.as<std::uint64_t>(), s);
    std::uint64_t* sorted = nullptr;
    allocations +=
        sort_keys(keys.as<std::uint64_t>(), scratch.as<std::uint64_t>(), count, 2 * id_bits, temp, &sorted, s);
    launch_unpack_pairs(sorted, count, id_bits, pairs, s);
    return allocations;
  }
  unsigned long long* per_object = scratch.as<unsigned long long>();
  std::uint64_t* starts = scratch.as<std::uint64_t>() + objects;
  const uint2* in = reinterpret_cast<const uint2*>(pairs);
  check_cuda(cudaMemsetAsync(per_object, 0, std::size_t{objects} * 8, s), "bucket counts");
  bucket_count_kernel<<<grid_for(count), kThreads, 0, s>>>(in, count, per_object);
  check_cuda(cudaGetLastError(), "bucket count kernel");
  allocations += inclusive_sum(reinterpret_cast<const std::uint64_t*>(per_object), starts, objects, temp, s);
  bucket_scatter_kernel<<<grid_for(count), kThreads, 0, s>>>(in, count, starts, per_object, keys.as<std::uint64_t>());
  check_cuda(cudaGetLastError(), "bucket scatter kernel");
  // Keys are unique, so the unstable segmented sort gives the one order.
  allocations += segmented_sort_keys(keys.as<std::uint64_t>(), reinterpret_cast<std::uint64_t*>(pairs), count,
                                     objects, starts, temp, s);
  return allocations;
}

}  // namespace hbp::cuda
