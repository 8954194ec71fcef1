// SPDX-License-Identifier: MIT
#pragma once
// The frame's kernels (device_kernels.cu): each a thin CUDA wrapper around a
// body of frame_bodies.hpp, launched on the given stream.
#include <cuda_runtime.h>

#include <cstdint>

#include "cuda/frame_bodies.hpp"
#include "cuda/device_support.cuh"
#include "hbp/cell_region.hpp"

namespace hbp::cuda {

// Boxes that fit the accelerator's buffer memories (shared memory) are
// swept there; a cell larger than the big-cell buffer is swept from global
// memory by the same body. 256 boxes (7 KiB) and 64 lanes per block: the grid targets ~16 boxes per
// cell (~35 references), and 32 such blocks fill an SM's 2048 threads
// within its shared memory.
inline constexpr std::uint32_t kBlockBoxes = 256;
inline constexpr std::uint32_t kLanes = 64;
// Larger cells, from dense regions: 256 lanes, up to 1280 boxes in shared
// memory (40 KiB, under the 48 KiB a block gets without opting in), on a
// fixed grid of kBigCellBlocks blocks (two per SM of an H100/H200).
inline constexpr std::uint32_t kBigLanes = 256;
inline constexpr std::uint32_t kBigCellBoxes = 1280;
inline constexpr std::uint32_t kBigCellBlocks = 264;

// acc[0..2] ordered min of lo, acc[3..5] ordered max of hi, acc[6] the first
// defective object (n when none), from acc[kBoundsExtents] the extent
// histogram (ExtentHistogram's layout, 3 * kExtentBins counts); acc must hold
// {~0 x3, 0 x3, n} and zero counts before. With `packed` (6 n floats), box i
// is also written to packed[6 i ..] as min x, y, z, max x, y, z.
inline constexpr std::uint32_t kBoundsExtents = 8;
inline constexpr std::uint32_t kBoundsWords = kBoundsExtents + 3 * kExtentBins;
void launch_bounds(const BoxLanesView& b, std::uint32_t n, std::uint32_t* acc, cudaStream_t s,
                   float* packed = nullptr);
// Rows of an (n, 6) array (element strides) into six lanes of n floats.
void launch_rows_to_lanes(const float* rows, std::int64_t row_stride, std::int64_t column_stride, std::uint32_t n,
                          float* lanes, cudaStream_t s);
// count[i]: box i's references in the low word, 1 in the high word when it
// is large (one scan gives both offsets); is_large[i] the flag.
void launch_reference_count(const GridView& g, const BoxLanesView& b, std::uint32_t n, std::uint64_t* count,
                            std::uint32_t* is_large, cudaStream_t s);
// offset: the exclusive scan of count (n + 1 entries): the reference slot in
// the low word, the large-list slot in the high word. Keys of position_bits
// `bits` (frame_bodies.hpp).
void launch_emit(const GridView& g, const BoxLanesView& b, std::uint32_t n, int bits, const std::uint32_t* is_large,
                 const std::uint64_t* offset, std::uint32_t* keys, std::uint32_t* ids, std::uint32_t* large_list,
                 cudaStream_t s);
// Sorted lanes from the sorted ids (64-bit keys, the high word a group such
// as the axis sweep's); head[r] = 1 where the high word changes.
void launch_gather(const BoxLanesView& b, const std::uint64_t* keys, const std::uint32_t* ids, std::uint32_t refs,
                   float* lanes, std::uint32_t* head, cudaStream_t s);
// The frame's gather: sorted lanes and positions from the sorted keys and
// ids and the boxes packed by launch_bounds; head[r] = 1 where a cell starts.
void launch_gather_cells(const float* packed, const std::uint32_t* keys, const std::uint32_t* ids, std::uint32_t refs,
                         int bits, float* lanes, std::uint32_t* positions, std::uint32_t* head, cudaStream_t s);
// The gather of the per-reference sweep: sorted lanes only (its rows find
// their cell from the keys); *cells (zeroed before) gains the cell starts.
void launch_gather_lanes(const float* packed, const std::uint32_t* keys, const std::uint32_t* ids, std::uint32_t refs,
                         int bits, float* lanes, std::uint32_t* cells, cudaStream_t s);
// From the inclusive scan of head: cell_begin (cells + 1), cell ids,
// regions, *cells.
void launch_cells(const GridView& g, const std::uint32_t* keys, int bits, const std::uint32_t* head_scan,
                  std::uint32_t refs, std::uint32_t* cell_begin, std::uint32_t* cell_ids, CellRegion* regions,
                  std::uint32_t* cells, cudaStream_t s);
// The accelerator over `blocks` >= *cells cells: a block per cell of up to
// kBlockBoxes boxes (blocks past *cells return), the larger cells listed in
// big_cells (1 + cells words) and swept on the fixed grid of big-cell
// blocks; counts[r] for each lane, or with `out` the pairs (two uint32
// each) from offsets[r].
void launch_cell_rows(const GridView& g, const CellLanes& sorted, int bits, const std::uint32_t* cell_begin,
                      const std::uint32_t* cell_ids, const CellRegion* regions, const std::uint32_t* cells,
                      std::uint32_t blocks, std::uint32_t* big_cells, std::uint64_t* counts,
                      const std::uint64_t* offsets, std::uint32_t* out, cudaStream_t s);
// The same rows with a thread per reference (refs threads), reading
// sorted.position as the whole sorted keys (cell above `bits` bits of
// position): a row's stop key ends it at its cell's end too, so it needs no
// cell table.
// The counting launch keeps each row's first kInlinePairs pairs in kept[r]
// (refs entries); the filling launch, given the same kept, copies them for
// the rows that had no more instead of sweeping those rows again.
inline constexpr std::uint32_t kInlinePairs = 2;
struct RowPairs {
  uint2 pair[kInlinePairs];
};
static_assert(sizeof(RowPairs) == 8 * kInlinePairs);
void launch_reference_rows(const GridView& g, const CellLanes& sorted, int bits, std::uint32_t refs, RowPairs* kept,
                           std::uint64_t* counts, const std::uint64_t* offsets, std::uint32_t* out, cudaStream_t s);
// A sorted frame's rows and large pass in one launch each, counting and
// writing (no per-row counts): pairs appended to `out` in blocks reserved
// with atomics on *total (zeroed here), so their order varies between runs;
// the pair order pass makes it the sorted list. *total counts every pair;
// past `capacity` pairs nothing more is written (the caller runs it again
// with room for *total).
void launch_append_rows(const GridView& g, const CellLanes& sorted, int bits, std::uint32_t refs,
                        const BoxLanesView& b, std::uint32_t n, const std::uint32_t* is_large,
                        const std::uint32_t* large_list, std::uint32_t large, std::uint32_t chunk,
                        unsigned long long* total, std::uint64_t capacity, std::uint32_t* out, cudaStream_t s);
// One cell of `size` boxes sorted by exact min x (the "cuda" cell engine),
// swept by one block with sweep_row; counts and pairs as above.
void launch_sorted_cell_rows(const SortedLanes& sorted, std::uint32_t size, const CellRegion& region,
                             std::uint64_t* counts, const std::uint64_t* offsets, std::uint32_t* out, cudaStream_t s);
// A batch of such cells back to back, block k sweeping boxes [starts[k],
// starts[k + 1]) (device arrays) with ids local to its cell: `batch.id` is
// 0, 1, 2, ... for at least the largest cell.
void launch_sorted_batch_rows(const SortedLanes& batch, std::uint32_t cells, const std::uint32_t* starts,
                              const CellRegion* regions, std::uint64_t* counts, const std::uint64_t* offsets,
                              std::uint32_t* out, cudaStream_t s);
// The large pass: slot q = (large index) * chunks + chunk, as cell rows.
void launch_large_rows(const BoxLanesView& b, std::uint32_t n, const std::uint32_t* is_large,
                       const std::uint32_t* large_list, std::uint32_t large, std::uint32_t chunk, std::uint64_t* counts,
                       const std::uint64_t* offsets, std::uint32_t* out, cudaStream_t s);
// The axis sweep peer: sums and sums of squares of the centres (min + max)
// per axis into sums[0..5] (zeroed before; double atomics: the axis choice
// may differ in the last bits between runs, the pairs never), the sort keys
// (ordered min on the lanes' first axis, ids 0..n-1), and a thread per row
// of the whole scene sweeping it (counts, or with `out` the pairs).
void launch_centre_sums(const BoxLanesView& b, std::uint32_t n, double* sums, cudaStream_t s);
void launch_axis_keys(const BoxLanesView& b, std::uint32_t n, std::uint64_t* keys, std::uint32_t* ids, cudaStream_t s);
void launch_scene_rows(const SortedLanes& sorted, std::uint32_t n, std::uint64_t* counts, const std::uint64_t* offsets,
                       std::uint32_t* out, cudaStream_t s);

// Pairs <-> 64-bit keys (a << id_bits | b, ids below 2^id_bits) for sorting
// by (a, b) over 2 * id_bits bits only.
void launch_pack_pairs(const std::uint32_t* pairs, std::uint64_t count, int id_bits, std::uint64_t* keys,
                       cudaStream_t s);
void launch_unpack_pairs(const std::uint64_t* keys, std::uint64_t count, int id_bits, std::uint32_t* pairs,
                         cudaStream_t s);
// Orders `count` canonical pairs of ids below `objects` (interleaved a, b
// words) in place by (a, b), as `order` says: Radix packs them into keys,
// radix-sorts over the bits ids use and unpacks; Buckets counts pairs per
// a, scans, scatters each pair into its a's bucket and sorts the buckets by
// b. `keys` and `scratch` are kept buffers of at least pair_order_bytes;
// returns how many of keys, scratch and temp it had to allocate.
enum class PairOrder;  // hbp/cuda/frame_broadphase.hpp
struct PairOrderBytes {
  std::size_t keys = 0, scratch = 0;
};
PairOrderBytes pair_order_bytes(PairOrder order, std::uint64_t count, std::uint32_t objects);
int sort_pairs_by_ab(PairOrder order, std::uint32_t* pairs, std::uint64_t count, std::uint32_t objects,
                     DeviceBuffer& keys, DeviceBuffer& scratch, DeviceBuffer& temp, cudaStream_t s);

}  // namespace hbp::cuda
