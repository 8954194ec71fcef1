// SPDX-License-Identifier: MIT
#include "cuda/device_kernels.cuh"

#include "cuda/device_primitives.cuh"
#include "cuda/device_support.cuh"

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

// Grid-stride; each thread folds its boxes, each warp folds its threads, lane
// 0 folds into acc with atomics (min/max commute: the result is exact and
// independent of order).
__global__ void bounds_kernel(BoxLanesView b, std::uint32_t n, std::uint32_t* acc) {
  std::uint32_t lo[3] = {~0u, ~0u, ~0u}, hi[3] = {0, 0, 0}, bad = n;
  for (std::uint32_t i = blockIdx.x * blockDim.x + threadIdx.x; i < n; i += gridDim.x * blockDim.x) {
    if (box_defect(b, i)) {
      bad = min(bad, i);
      continue;
    }
    for (int k = 0; k < 3; ++k) {
      lo[k] = min(lo[k], ordered_bits(b.lo[k][i]));
      hi[k] = max(hi[k], ordered_bits(b.hi[k][i]));
    }
  }
  for (int k = 0; k < 3; ++k) {
    lo[k] = warp_min(lo[k]);
    hi[k] = warp_max(hi[k]);
  }
  bad = warp_min(bad);
  if ((threadIdx.x & 31u) == 0) {
    for (int k = 0; k < 3; ++k) {
      atomicMin(acc + k, lo[k]);
      atomicMax(acc + 3 + k, hi[k]);
    }
    atomicMin(acc + 6, bad);
  }
}

__global__ void reference_count_kernel(GridView g, BoxLanesView b, std::uint32_t n, std::uint32_t* count,
                                       std::uint32_t* is_large) {
  const std::uint32_t i = blockIdx.x * blockDim.x + threadIdx.x;
  if (i >= n) return;
  const std::uint32_t c = reference_count(g, b, i);
  count[i] = c;
  is_large[i] = c == 0;
}

__global__ void emit_kernel(GridView g, BoxLanesView b, std::uint32_t n, const std::uint32_t* is_large,
                            const std::uint32_t* ref_offset, const std::uint32_t* large_offset, std::uint64_t* keys,
                            std::uint32_t* ids, std::uint32_t* large_list) {
  const std::uint32_t i = blockIdx.x * blockDim.x + threadIdx.x;
  if (i >= n) return;
  if (is_large[i])
    large_list[large_offset[i]] = i;
  else
    emit_references(g, b, i, keys, ids, ref_offset[i]);
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

__global__ void cells_kernel(GridView g, const std::uint64_t* keys, const std::uint32_t* head_scan,
                             std::uint32_t refs, std::uint32_t* cell_begin, CellRegion* regions,
                             std::uint32_t* cells) {
  const std::uint32_t r = blockIdx.x * blockDim.x + threadIdx.x;
  if (r >= refs) return;
  if (r == 0 || head_scan[r] != head_scan[r - 1]) {
    const std::uint32_t c = head_scan[r] - 1;
    cell_begin[c] = r;
    regions[c] = cell_region(g, static_cast<std::uint32_t>(keys[r] >> 32));
  }
  if (r + 1 == refs) {
    cell_begin[head_scan[r]] = refs;
    *cells = head_scan[r];
  }
}

// The accelerator: one block per cell, its boxes copied into shared memory
// (the buffer memories), each lane sweeping its rows (r, r + kLanes, ...).
__global__ void __launch_bounds__(kLanes) cell_rows_kernel(SortedLanes sorted, const std::uint32_t* cell_begin,
                                                           const CellRegion* regions, const std::uint32_t* cells,
                                                           std::uint64_t* counts, const std::uint64_t* offsets,
                                                           std::uint32_t* out) {
  __shared__ float buffer[6][kBlockBoxes];
  __shared__ std::uint32_t buffer_ids[kBlockBoxes];
  const std::uint32_t c = blockIdx.x;
  if (c >= *cells) return;
  const std::uint32_t begin = cell_begin[c], size = cell_begin[c + 1] - begin;
  const CellRegion region = regions[c];
  SortedLanes s = sorted;
  std::uint32_t base = begin;  // row r of s is reference base + r
  if (size <= kBlockBoxes) {
    for (std::uint32_t r = threadIdx.x; r < size; r += blockDim.x) {
      for (int k = 0; k < 3; ++k) {
        buffer[k][r] = sorted.lo[k][begin + r];
        buffer[3 + k][r] = sorted.hi[k][begin + r];
      }
      buffer_ids[r] = sorted.id[begin + r];
    }
    __syncthreads();
    s = SortedLanes{{buffer[0], buffer[1], buffer[2]}, {buffer[3], buffer[4], buffer[5]}, buffer_ids};
    base = 0;
  }
  for (std::uint32_t r = threadIdx.x; r < size; r += blockDim.x) {
    if (!out) {
      counts[begin + r] = sweep_row(s, base + r, base + size, region, [](std::uint32_t, std::uint32_t, std::uint32_t) {});
    } else {
      std::uint32_t* row = out + 2 * offsets[begin + r];
      sweep_row(s, base + r, base + size, region, [row](std::uint32_t k, std::uint32_t a, std::uint32_t b) {
        row[2 * k] = a < b ? a : b;
        row[2 * k + 1] = a < b ? b : a;
      });
    }
  }
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

__global__ void pack_kernel(const std::uint32_t* pairs, std::uint64_t count, std::uint64_t* keys) {
  const std::uint64_t p = std::uint64_t{blockIdx.x} * blockDim.x + threadIdx.x;
  if (p < count) keys[p] = (std::uint64_t{pairs[2 * p]} << 32) | pairs[2 * p + 1];
}

__global__ void unpack_kernel(const std::uint64_t* keys, std::uint64_t count, std::uint32_t* pairs) {
  const std::uint64_t p = std::uint64_t{blockIdx.x} * blockDim.x + threadIdx.x;
  if (p < count) {
    pairs[2 * p] = static_cast<std::uint32_t>(keys[p] >> 32);
    pairs[2 * p + 1] = static_cast<std::uint32_t>(keys[p]);
  }
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

void launch_bounds(const BoxLanesView& b, std::uint32_t n, std::uint32_t* acc, cudaStream_t s) {
  bounds_kernel<<<blocks_for(n) < 1024 ? blocks_for(n) : 1024, kThreads, 0, s>>>(b, n, acc);
  check_cuda(cudaGetLastError(), "bounds kernel");
}

void launch_reference_count(const GridView& g, const BoxLanesView& b, std::uint32_t n, std::uint32_t* count,
                            std::uint32_t* is_large, cudaStream_t s) {
  if (!n) return;
  reference_count_kernel<<<grid_for(n), kThreads, 0, s>>>(g, b, n, count, is_large);
  check_cuda(cudaGetLastError(), "reference count kernel");
}

void launch_emit(const GridView& g, const BoxLanesView& b, std::uint32_t n, const std::uint32_t* is_large,
                 const std::uint32_t* ref_offset, const std::uint32_t* large_offset, std::uint64_t* keys,
                 std::uint32_t* ids, std::uint32_t* large_list, cudaStream_t s) {
  if (!n) return;
  emit_kernel<<<grid_for(n), kThreads, 0, s>>>(g, b, n, is_large, ref_offset, large_offset, keys, ids, large_list);
  check_cuda(cudaGetLastError(), "emit kernel");
}

void launch_gather(const BoxLanesView& b, const std::uint64_t* keys, const std::uint32_t* ids, std::uint32_t refs,
                   float* lanes, std::uint32_t* head, cudaStream_t s) {
  if (!refs) return;
  gather_kernel<<<grid_for(refs), kThreads, 0, s>>>(b, keys, ids, refs, lanes, head);
  check_cuda(cudaGetLastError(), "gather kernel");
}

void launch_cells(const GridView& g, const std::uint64_t* keys, const std::uint32_t* head_scan, std::uint32_t refs,
                  std::uint32_t* cell_begin, CellRegion* regions, std::uint32_t* cells, cudaStream_t s) {
  if (!refs) return;
  cells_kernel<<<grid_for(refs), kThreads, 0, s>>>(g, keys, head_scan, refs, cell_begin, regions, cells);
  check_cuda(cudaGetLastError(), "cells kernel");
}

void launch_cell_rows(const SortedLanes& sorted, const std::uint32_t* cell_begin, const CellRegion* regions,
                      const std::uint32_t* cells, std::uint32_t blocks, std::uint64_t* counts,
                      const std::uint64_t* offsets, std::uint32_t* out, cudaStream_t s) {
  if (!blocks) return;
  cell_rows_kernel<<<blocks, kLanes, 0, s>>>(sorted, cell_begin, regions, cells, counts, offsets, out);
  check_cuda(cudaGetLastError(), "cell rows kernel");
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

void launch_pack_pairs(const std::uint32_t* pairs, std::uint64_t count, std::uint64_t* keys, cudaStream_t s) {
  if (!count) return;
  pack_kernel<<<grid_for(count), kThreads, 0, s>>>(pairs, count, keys);
  check_cuda(cudaGetLastError(), "pack kernel");
}

void launch_unpack_pairs(const std::uint64_t* keys, std::uint64_t count, std::uint32_t* pairs, cudaStream_t s) {
  if (!count) return;
  unpack_kernel<<<grid_for(count), kThreads, 0, s>>>(keys, count, pairs);
  check_cuda(cudaGetLastError(), "unpack kernel");
}

int sort_pairs_by_ab(std::uint32_t* pairs, std::uint64_t count, DeviceBuffer& keys, DeviceBuffer& keys_alt,
                     DeviceBuffer& temp, cudaStream_t s) {
  int allocations = int(keys.reserve(count * 8)) + int(keys_alt.reserve(count * 8));
  launch_pack_pairs(pairs, count, keys.as<std::uint64_t>(), s);
  std::uint64_t* sorted = nullptr;
  allocations += sort_keys(keys.as<std::uint64_t>(), keys_alt.as<std::uint64_t>(), count, temp, &sorted, s);
  launch_unpack_pairs(sorted, count, pairs, s);
  return allocations;
}

}  // namespace hbp::cuda
