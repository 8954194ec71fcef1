// SPDX-License-Identifier: MIT
#include "cuda/device_cell.hpp"

#include <cuda_runtime.h>

#include <string>
#include <utility>

#include "cuda/device_kernels.cuh"
#include "cuda/device_support.cuh"
#include "hbp/error.hpp"

namespace hbp::cuda {

struct DeviceCell::State {
  cudaStream_t stream = nullptr;
  DeviceBuffer lanes, ids, counts, offsets, pairs;
  ~State() {
    if (stream) cudaStreamDestroy(stream);
  }
};

DeviceCell::DeviceCell() : state_(std::make_unique<State>()) {
  require_device();
  check_cuda(cudaStreamCreateWithFlags(&state_->stream, cudaStreamNonBlocking), "cudaStreamCreate");
}

DeviceCell::~DeviceCell() = default;

void DeviceCell::run(const CellSweep& sorted, const CellRegion& region, std::uint64_t pair_limit,
                     std::vector<Pair>& out) {
  State& st = *state_;
  const std::uint32_t n = sorted.size();
  if (n < 2) return;
  const cudaStream_t s = st.stream;
  st.lanes.reserve(std::size_t{6} * n * sizeof(float));
  st.ids.reserve(std::size_t{n} * 4);
  st.counts.reserve(std::size_t{n} * 8);
  st.offsets.reserve(std::size_t{n} * 8);
  float* lanes = st.lanes.as<float>();
  for (int l = 0; l < 6; ++l)
    check_cuda(cudaMemcpyAsync(lanes + static_cast<std::size_t>(l) * n, l < 3 ? sorted.lo(l) : sorted.hi(l - 3), n * sizeof(float),
                               cudaMemcpyHostToDevice, s),
               "cell upload");
  check_cuda(cudaMemcpyAsync(st.ids.as<std::uint32_t>(), sorted.ids(), n * 4, cudaMemcpyHostToDevice, s), "ids upload");
  const SortedLanes lanes_view{{lanes, lanes + n, lanes + 2 * std::size_t{n}},
                               {lanes + 3 * std::size_t{n}, lanes + 4 * std::size_t{n}, lanes + 5 * std::size_t{n}},
                               st.ids.as<std::uint32_t>()};
  launch_sorted_cell_rows(lanes_view, n, region, st.counts.as<std::uint64_t>(), nullptr, nullptr, s);
  counts_.resize(n);
  check_cuda(cudaMemcpyAsync(counts_.data(), st.counts.as<std::uint64_t>(), n * 8, cudaMemcpyDeviceToHost, s), "counts");
  check_cuda(cudaStreamSynchronize(s), "cell count");
  std::uint64_t total = 0;
  for (auto& c : counts_) total += std::exchange(c, total);
  if (total > pair_limit)
    throw CapacityExceeded("cell of " + std::to_string(n) + " boxes has more than " + std::to_string(pair_limit) +
                           " overlapping pairs (max_pairs)");
  if (!total) return;
  st.pairs.reserve(total * 8);
  check_cuda(cudaMemcpyAsync(st.offsets.as<std::uint64_t>(), counts_.data(), n * 8, cudaMemcpyHostToDevice, s),
             "offsets");
  launch_sorted_cell_rows(lanes_view, n, region, nullptr, st.offsets.as<std::uint64_t>(), st.pairs.as<std::uint32_t>(),
                          s);
  const std::size_t base = out.size();
  out.resize(base + total);
  check_cuda(cudaMemcpyAsync(out.data() + base, st.pairs.as<std::uint32_t>(), total * 8, cudaMemcpyDeviceToHost, s),
             "pairs download");
  check_cuda(cudaStreamSynchronize(s), "cell fill");
}

}  // namespace hbp::cuda
