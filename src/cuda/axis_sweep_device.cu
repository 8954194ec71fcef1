// SPDX-License-Identifier: MIT
// AxisSweep on a CUDA device (the boxes were validated by the facade):
// centre sums for the axis, keys, a stable radix sort, gather, a thread per
// box counting then filling its sweep, optional (a, b) order. Buffers kept
// across frames.
#include <cuda_runtime.h>

#include <cstring>

#include "cuda/axis_sweep_impl.hpp"
#include "cuda/device_kernels.cuh"
#include "cuda/device_primitives.cuh"
#include "cuda/device_support.cuh"
#include "cuda/frame_impl.hpp"

namespace hbp::cuda {
namespace {

class DeviceAxisSweep final : public AxisSweep::Impl {
 public:
  explicit DeviceAxisSweep(const FrameOptions& o) : Impl(o), device_(require_device()) {
    check_cuda(cudaStreamCreateWithFlags(&stream_, cudaStreamNonBlocking), "cudaStreamCreate");
    for (auto& e : events_) check_cuda(cudaEventCreate(&e), "cudaEventCreate");
    check_cuda(cudaMallocHost(&pinned_, 8 * sizeof(double)), "cudaMallocHost");
  }
  ~DeviceAxisSweep() override {
    const DeviceScope scope(device_);
    for (auto& e : events_) cudaEventDestroy(e);
    cudaStreamDestroy(stream_);
    cudaFreeHost(pinned_);
  }

  void run(const Lanes& in) override {
    const DeviceScope scope(device_);
    info = {};
    const std::uint32_t n = in.n;
    record(0);
    reserve(boxes_, std::size_t{6} * n * sizeof(float) + 4);
    float* lanes[6];
    for (int l = 0; l < 6; ++l) {
      lanes[l] = boxes_.as<float>() + static_cast<std::size_t>(l) * n;
      if (n)
        check_cuda(cudaMemcpyAsync(lanes[l], l < 3 ? in.lo[l] : in.hi[l - 3], n * sizeof(float),
                                   cudaMemcpyHostToDevice, stream_),
                   "upload");
    }
    record(1);
    reserve(sums_, 8 * sizeof(double));
    check_cuda(cudaMemsetAsync(sums_.as<double>(), 0, 6 * sizeof(double), stream_), "sums init");
    const BoxLanesView raw{{lanes[0], lanes[1], lanes[2]}, {lanes[3], lanes[4], lanes[5]}};
    launch_centre_sums(raw, n, sums_.as<double>(), stream_);
    check_cuda(cudaMemcpyAsync(pinned_, sums_.as<double>(), 6 * sizeof(double), cudaMemcpyDeviceToHost, stream_), "sums");
    sync();
    axis = largest_variance_axis(pinned_, pinned_ + 3, n);
    const int a1 = (axis + 1) % 3, a2 = (axis + 2) % 3;
    const BoxLanesView b{{lanes[axis], lanes[a1], lanes[a2]}, {lanes[3 + axis], lanes[3 + a1], lanes[3 + a2]}};
    reserve(keys_, (std::size_t{n} + 1) * 8);
    reserve(keys_alt_, (std::size_t{n} + 1) * 8);
    reserve(ids_, (std::size_t{n} + 1) * 4);
    reserve(ids_alt_, (std::size_t{n} + 1) * 4);
    launch_axis_keys(b, n, keys_.as<std::uint64_t>(), ids_.as<std::uint32_t>(), stream_);
    std::uint64_t* keys = nullptr;
    std::uint32_t* ids = nullptr;
    if (sort_pairs(keys_.as<std::uint64_t>(), keys_alt_.as<std::uint64_t>(), ids_.as<std::uint32_t>(),
                   ids_alt_.as<std::uint32_t>(), n, 32, temp_, &keys, &ids, stream_))
      ++info.allocations;
    reserve(sorted_, std::size_t{6} * (n + 1) * sizeof(float));
    reserve(head_, (std::size_t{n} + 1) * 4);
    launch_gather(b, keys, ids, n, sorted_.as<float>(), head_.as<std::uint32_t>(), stream_);
    record(2);
    const float* s = sorted_.as<float>();
    const SortedLanes lanes_view{{s, s + n, s + 2 * std::size_t{n}},
                                 {s + 3 * std::size_t{n}, s + 4 * std::size_t{n}, s + 5 * std::size_t{n}},
                                 ids};
    reserve(counts_, (std::size_t{n} + 1) * 8);
    reserve(offsets_, (std::size_t{n} + 1) * 8);
    launch_scene_rows(lanes_view, n, counts_.as<std::uint64_t>(), nullptr, nullptr, stream_);
    if (inclusive_sum(counts_.as<std::uint64_t>(), offsets_.as<std::uint64_t>(), n, temp_, stream_)) ++info.allocations;
    check_cuda(cudaMemcpyAsync(pinned_, offsets_.as<std::uint64_t>() + n, 8, cudaMemcpyDeviceToHost, stream_), "total");
    sync();
    std::uint64_t total;
    std::memcpy(&total, pinned_, sizeof total);
    record(3);
    if (options.max_pairs && total > options.max_pairs) throw_too_many_pairs(total, options.max_pairs);
    reserve(pairs_, (total + 1) * 8);
    launch_scene_rows(lanes_view, n, nullptr, offsets_.as<std::uint64_t>(), pairs_.as<std::uint32_t>(), stream_);
    record(4);
    std::uint32_t* out = pairs_.as<std::uint32_t>();
    if (options.sorted && total > 1) {
      info.allocations += sort_pairs_by_ab(options.pair_order, out, total, n, pair_keys_, pair_keys_alt_, temp_, stream_);
    }
    record(5);
    pairs.resize(total);
    if (total)
      check_cuda(cudaMemcpyAsync(pairs.data(), out, total * sizeof(Pair), cudaMemcpyDeviceToHost, stream_), "download");
    record(6);
    sync();
    info.pairs = total;
    StageTimes& t = info.times;
    t.upload_ms = between(0, 1);
    t.sort_ms = between(1, 2);
    t.count_ms = between(2, 3);
    t.fill_ms = between(3, 4);
    t.order_ms = between(4, 5);
    t.download_ms = between(5, 6);
    t.frame_ms = between(1, 5);
  }

 private:
  void reserve(DeviceBuffer& buffer, std::size_t bytes) {
    if (buffer.reserve(bytes)) ++info.allocations;
  }
  void record(int e) { check_cuda(cudaEventRecord(events_[e], stream_), "cudaEventRecord"); }
  void sync() { check_cuda(cudaStreamSynchronize(stream_), "cudaStreamSynchronize"); }
  double between(int a, int b) {
    float ms = 0;
    check_cuda(cudaEventElapsedTime(&ms, events_[a], events_[b]), "cudaEventElapsedTime");
    return ms;
  }

  int device_;  // the device current when it was made: its calls run there
  cudaStream_t stream_ = nullptr;
  cudaEvent_t events_[7] = {};
  double* pinned_ = nullptr;
  DeviceBuffer boxes_, sums_, keys_, keys_alt_, ids_, ids_alt_, sorted_, head_, counts_, offsets_, pairs_, pair_keys_,
      pair_keys_alt_, temp_;
};

}  // namespace

std::unique_ptr<AxisSweep::Impl> make_device_axis_sweep(const FrameOptions& options) {
  return std::make_unique<DeviceAxisSweep>(options);
}

}  // namespace hbp::cuda
