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
// swept there; a larger cell is swept from global memory by the same body.
// 256 boxes (7 KiB) and 64 lanes per block: the grid targets ~16 boxes per
// cell (~35 references), and 32 such blocks fill an SM's 2048 threads
// within its shared memory.
inline constexpr std::uint32_t kBlockBoxes = 256;
inline constexpr std::uint32_t kLanes = 64;

// acc[0..2] ordered min of lo, acc[3..5] ordered max of hi, acc[6] the first
// defective object (n when none); acc must hold {~0 x3, 0 x3, n} before.
void launch_bounds(const BoxLanesView& b, std::uint32_t n, std::uint32_t* acc, cudaStream_t s);
void launch_reference_count(const GridView& g, const BoxLanesView& b, std::uint32_t n, std::uint32_t* count,
                            std::uint32_t* is_large, cudaStream_t s);
// ref_offset / large_offset: exclusive offsets (n + 1 entries).
void launch_emit(const GridView& g, const BoxLanesView& b, std::uint32_t n, const std::uint32_t* is_large,
                 const std::uint32_t* ref_offset, const std::uint32_t* large_offset, std::uint64_t* keys,
                 std::uint32_t* ids, std::uint32_t* large_list, cudaStream_t s);
// Sorted lanes from the sorted ids; head[r] = 1 where a cell starts.
void launch_gather(const BoxLanesView& b, const std::uint64_t* keys, const std::uint32_t* ids, std::uint32_t refs,
                   float* lanes, std::uint32_t* head, cudaStream_t s);
// From the inclusive scan of head: cell_begin (cells + 1), regions, *cells.
void launch_cells(const GridView& g, const std::uint64_t* keys, const std::uint32_t* head_scan, std::uint32_t refs,
                  std::uint32_t* cell_begin, CellRegion* regions, std::uint32_t* cells, cudaStream_t s);
// A block per cell (blocks past *cells return): counts[r] for each lane, or
// with `out` the pairs (two uint32 each) from offsets[r].
void launch_cell_rows(const SortedLanes& sorted, const std::uint32_t* cell_begin, const CellRegion* regions,
                      const std::uint32_t* cells, std::uint32_t blocks, std::uint64_t* counts,
                      const std::uint64_t* offsets, std::uint32_t* out, cudaStream_t s);
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

// Pairs <-> 64-bit keys (a << 32 | b) for sorting by (a, b).
void launch_pack_pairs(const std::uint32_t* pairs, std::uint64_t count, std::uint64_t* keys, cudaStream_t s);
void launch_unpack_pairs(const std::uint64_t* keys, std::uint64_t count, std::uint32_t* pairs, cudaStream_t s);
// Orders `count` pairs (interleaved a, b words) in place by (a, b): packed
// into keys, radix-sorted (keys_alt and temp as the sort's room), unpacked.
// Returns how many of the three buffers it had to allocate.
int sort_pairs_by_ab(std::uint32_t* pairs, std::uint64_t count, DeviceBuffer& keys, DeviceBuffer& keys_alt,
                     DeviceBuffer& temp, cudaStream_t s);

}  // namespace hbp::cuda
