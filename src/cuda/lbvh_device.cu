// SPDX-License-Identifier: MIT
// Lbvh on a CUDA device (the boxes were validated by the facade): the
// frame's bounds kernel, Morton keys, CUB's radix sort, gather, the radix
// tree, its bounds bottom-up (a visit count per internal node), a thread per
// leaf counting then filling its traversal, optional (a, b) order. One
// read-back per frame (the pair count, which sizes the pair buffer and is
// checked against max_pairs before any pair is written). Buffers kept
// across frames.
#include <cuda_runtime.h>

#include <cstring>

#include "cuda/device_kernels.cuh"
#include "cuda/device_primitives.cuh"
#include "cuda/device_support.cuh"
#include "cuda/frame_impl.hpp"
#include "cuda/lbvh_bodies.hpp"
#include "cuda/lbvh_impl.hpp"

namespace hbp::cuda {
namespace {

constexpr unsigned kThreads = 256;

unsigned grid_for(std::uint64_t n) { return static_cast<unsigned>((n + kThreads - 1) / kThreads); }

__global__ void morton_kernel(BoxLanesView b, std::uint32_t n, const std::uint32_t* bounds, std::uint64_t* keys) {
  const std::uint32_t i = blockIdx.x * blockDim.x + threadIdx.x;
  if (i < n) keys[i] = morton_key(bounds, b, i);
}

// The boxes in key order (six lanes of n) and their object ids.
__global__ void gather_kernel(BoxLanesView b, const std::uint64_t* keys, std::uint32_t n, float* lanes,
                              std::uint32_t* ids) {
  const std::uint32_t r = blockIdx.x * blockDim.x + threadIdx.x;
  if (r >= n) return;
  const auto i = static_cast<std::uint32_t>(keys[r]);
  ids[r] = i;
  for (int k = 0; k < 3; ++k) {
    lanes[static_cast<std::size_t>(k) * n + r] = b.lo[k][i];
    lanes[static_cast<std::size_t>(3 + k) * n + r] = b.hi[k][i];
  }
}

__global__ void build_kernel(const std::uint64_t* keys, std::uint32_t n, LbvhNodes t) {
  const std::uint32_t i = blockIdx.x * blockDim.x + threadIdx.x;
  if (i + 1 < n) build_node(keys, n, i, t);
}

// visits zeroed before. The fences order each thread's node bounds before
// its arrival is counted, and the sibling's after it is seen (release and
// acquire at device scope, across blocks).
__global__ void refit_kernel(SortedLanes leaves, LbvhNodes t, std::uint32_t n, std::uint32_t* visits) {
  const std::uint32_t q = blockIdx.x * blockDim.x + threadIdx.x;
  if (q >= n) return;
  refit_from_leaf(leaves, t, q, [visits](std::uint32_t node) {
    __threadfence();
    if (atomicAdd(visits + node, 1u) == 0) return false;
    __threadfence();
    return true;
  });
}

__global__ void rows_kernel(SortedLanes leaves, LbvhNodes t, std::uint32_t n, std::uint64_t* counts,
                            const std::uint64_t* offsets, std::uint32_t* out) {
  const std::uint32_t p = blockIdx.x * blockDim.x + threadIdx.x;
  if (p >= n) return;
  if (!out) {
    counts[p] = lbvh_row(leaves, t, n, p, [](std::uint32_t, std::uint32_t, std::uint32_t) {});
  } else {
    std::uint32_t* row = out + 2 * offsets[p];
    lbvh_row(leaves, t, n, p, [row](std::uint32_t k, std::uint32_t a, std::uint32_t b) {
      row[2 * k] = a < b ? a : b;
      row[2 * k + 1] = a < b ? b : a;
    });
  }
}

enum Stage { kStart, kUploaded, kBounds, kSorted, kBuilt, kCounted, kFilled, kOrdered, kDownloaded, kStages };

class DeviceLbvh final : public Lbvh::Impl {
 public:
  explicit DeviceLbvh(const FrameOptions& o) : Impl(o), device_(require_device()) {
    check_cuda(cudaStreamCreateWithFlags(&stream_, cudaStreamNonBlocking), "cudaStreamCreate");
    for (auto& e : events_) check_cuda(cudaEventCreate(&e), "cudaEventCreate");
    check_cuda(cudaMallocHost(&pinned_, 8 * sizeof(std::uint64_t)), "cudaMallocHost");
  }
  ~DeviceLbvh() override {
    const DeviceScope scope(device_);
    for (auto& e : events_) cudaEventDestroy(e);
    cudaStreamDestroy(stream_);
    cudaFreeHost(pinned_);
  }

  void run(const Lanes& in) override {
    const DeviceScope scope(device_);
    info = {};
    const std::uint32_t n = in.n;
    const std::uint32_t nodes = n ? n - 1 : 0;
    record(kStart);
    reserve(boxes_, std::size_t{6} * n * sizeof(float) + 4);
    float* lanes[6];
    for (int l = 0; l < 6; ++l) {
      lanes[l] = boxes_.as<float>() + static_cast<std::size_t>(l) * n;
      if (n)
        check_cuda(cudaMemcpyAsync(lanes[l], l < 3 ? in.lo[l] : in.hi[l - 3], n * sizeof(float),
                                   cudaMemcpyHostToDevice, stream_),
                   "upload");
    }
    record(kUploaded);

    // Bounds: launch_bounds' accumulator, read by the Morton kernel in place.
    const BoxLanesView b{{lanes[0], lanes[1], lanes[2]}, {lanes[3], lanes[4], lanes[5]}};
    // (kBoundsWords: the extent histogram the kernel also fills, unused here.)
    reserve(acc_, kBoundsWords * sizeof(std::uint32_t));
    const std::uint32_t init[7] = {~0u, ~0u, ~0u, 0, 0, 0, n};
    std::memcpy(pinned_, init, sizeof init);
    check_cuda(cudaMemcpyAsync(acc_.as<std::uint32_t>(), pinned_, sizeof init, cudaMemcpyHostToDevice, stream_),
               "bounds init");
    check_cuda(cudaMemsetAsync(acc_.as<std::uint32_t>() + kBoundsExtents, 0, 3 * kExtentBins * sizeof(std::uint32_t),
                               stream_),
               "extents init");
    if (n) launch_bounds(b, n, acc_.as<std::uint32_t>(), stream_);
    record(kBounds);

    // Morton keys over indices, sorted; the boxes gathered in that order.
    reserve(keys_, (std::size_t{n} + 1) * 8);
    reserve(keys_alt_, (std::size_t{n} + 1) * 8);
    if (n) {
      morton_kernel<<<grid_for(n), kThreads, 0, stream_>>>(b, n, acc_.as<std::uint32_t>(), keys_.as<std::uint64_t>());
      check_cuda(cudaGetLastError(), "morton kernel");
    }
    std::uint64_t* keys = keys_.as<std::uint64_t>();
    if (sort_keys(keys_.as<std::uint64_t>(), keys_alt_.as<std::uint64_t>(), n, 64, temp_, &keys, stream_))
      ++info.allocations;
    reserve(sorted_, std::size_t{6} * (n + 1) * sizeof(float));
    reserve(ids_, (std::size_t{n} + 1) * 4);
    if (n) {
      gather_kernel<<<grid_for(n), kThreads, 0, stream_>>>(b, keys, n, sorted_.as<float>(), ids_.as<std::uint32_t>());
      check_cuda(cudaGetLastError(), "lbvh gather kernel");
    }
    const float* s = sorted_.as<float>();
    const SortedLanes leaves{{s, s + n, s + 2 * std::size_t{n}},
                             {s + 3 * std::size_t{n}, s + 4 * std::size_t{n}, s + 5 * std::size_t{n}},
                             ids_.as<std::uint32_t>()};
    record(kSorted);

    // The radix tree, then its bounds bottom-up.
    for (DeviceBuffer* d : {&left_, &right_, &last_, &node_parent_, &visits_}) reserve(*d, (std::size_t{nodes} + 1) * 4);
    reserve(leaf_parent_, (std::size_t{n} + 1) * 4);
    reserve(node_bounds_, std::size_t{6} * (nodes + 1) * sizeof(float));
    float* nb = node_bounds_.as<float>();
    const LbvhNodes tree{left_.as<std::uint32_t>(),
                         right_.as<std::uint32_t>(),
                         last_.as<std::uint32_t>(),
                         node_parent_.as<std::uint32_t>(),
                         leaf_parent_.as<std::uint32_t>(),
                         {nb, nb + nodes, nb + 2 * std::size_t{nodes}},
                         {nb + 3 * std::size_t{nodes}, nb + 4 * std::size_t{nodes}, nb + 5 * std::size_t{nodes}}};
    if (n >= 2) {
      build_kernel<<<grid_for(nodes), kThreads, 0, stream_>>>(keys, n, tree);
      check_cuda(cudaGetLastError(), "lbvh build kernel");
      check_cuda(cudaMemsetAsync(visits_.as<std::uint32_t>(), 0, std::size_t{nodes} * 4, stream_), "visits init");
      refit_kernel<<<grid_for(n), kThreads, 0, stream_>>>(leaves, tree, n, visits_.as<std::uint32_t>());
      check_cuda(cudaGetLastError(), "lbvh refit kernel");
    }
    record(kBuilt);

    // Count, scan, the total read back: max_pairs before any pair is written.
    reserve(counts_, (std::size_t{n} + 1) * 8);
    reserve(offsets_, (std::size_t{n} + 1) * 8);
    launch_rows(leaves, tree, n, nullptr, nullptr);
    if (inclusive_sum(counts_.as<std::uint64_t>(), offsets_.as<std::uint64_t>(), n, temp_, stream_)) ++info.allocations;
    check_cuda(cudaMemcpyAsync(pinned_, offsets_.as<std::uint64_t>() + n, 8, cudaMemcpyDeviceToHost, stream_), "total");
    sync();
    const std::uint64_t total = pinned_[0];
    record(kCounted);
    if (options.max_pairs && total > options.max_pairs) throw_too_many_pairs(total, options.max_pairs);
    reserve(pairs_, (total + 1) * 8);
    launch_rows(leaves, tree, n, offsets_.as<std::uint64_t>(), pairs_.as<std::uint32_t>());
    record(kFilled);
    std::uint32_t* out = pairs_.as<std::uint32_t>();
    if (options.sorted && total > 1)
      info.allocations += sort_pairs_by_ab(options.pair_order, out, total, n, pair_keys_, pair_keys_alt_, temp_, stream_);
    record(kOrdered);
    pairs.resize(total);
    if (total)
      check_cuda(cudaMemcpyAsync(pairs.data(), out, total * sizeof(Pair), cudaMemcpyDeviceToHost, stream_), "download");
    record(kDownloaded);
    sync();

    info.pairs = total;
    StageTimes& t = info.times;
    t.upload_ms = between(kStart, kUploaded);
    t.bounds_ms = between(kUploaded, kBounds);
    t.sort_ms = between(kBounds, kSorted);
    t.refs_ms = between(kSorted, kBuilt);
    t.count_ms = between(kBuilt, kCounted);
    t.fill_ms = between(kCounted, kFilled);
    t.order_ms = between(kFilled, kOrdered);
    t.download_ms = between(kOrdered, kDownloaded);
    t.frame_ms = between(kUploaded, kOrdered);
    std::size_t held = 0;
    for (const DeviceBuffer* d : {&boxes_, &acc_, &keys_, &keys_alt_, &sorted_, &ids_, &left_, &right_, &last_,
                                  &node_parent_, &leaf_parent_, &visits_, &node_bounds_, &counts_, &offsets_, &pairs_,
                                  &pair_keys_, &pair_keys_alt_, &temp_})
      held += d->capacity();
    info.buffer_bytes = held;
  }

 private:
  // counts (with out null), or the pairs (two uint32 each) from offsets.
  void launch_rows(const SortedLanes& leaves, const LbvhNodes& tree, std::uint32_t n, const std::uint64_t* offsets,
                   std::uint32_t* out) {
    if (!n) return;
    rows_kernel<<<grid_for(n), kThreads, 0, stream_>>>(leaves, tree, n, counts_.as<std::uint64_t>(), offsets, out);
    check_cuda(cudaGetLastError(), out ? "lbvh fill kernel" : "lbvh count kernel");
  }
  void reserve(DeviceBuffer& buffer, std::size_t bytes) {
    if (buffer.reserve(bytes)) ++info.allocations;
  }
  void record(Stage s) { check_cuda(cudaEventRecord(events_[s], stream_), "cudaEventRecord"); }
  void sync() { check_cuda(cudaStreamSynchronize(stream_), "cudaStreamSynchronize"); }
  double between(Stage a, Stage b) {
    float ms = 0;
    check_cuda(cudaEventElapsedTime(&ms, events_[a], events_[b]), "cudaEventElapsedTime");
    return ms;
  }

  int device_;  // the device current when it was made: its calls run there
  cudaStream_t stream_ = nullptr;
  cudaEvent_t events_[kStages] = {};
  std::uint64_t* pinned_ = nullptr;
  DeviceBuffer boxes_, acc_, keys_, keys_alt_, sorted_, ids_, left_, right_, last_, node_parent_, leaf_parent_,
      visits_, node_bounds_, counts_, offsets_, pairs_, pair_keys_, pair_keys_alt_, temp_;
};

}  // namespace

std::unique_ptr<Lbvh::Impl> make_device_lbvh(const FrameOptions& options) {
  return std::make_unique<DeviceLbvh>(options);
}

}  // namespace hbp::cuda
