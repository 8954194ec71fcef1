// SPDX-License-Identifier: MIT
#include "cuda/device_cell.hpp"

#include <cuda_runtime.h>

#include <algorithm>
#include <numeric>
#include <string>
#include <utility>

#include "cuda/device_kernels.cuh"
#include "cuda/device_support.cuh"
#include "hbp/error.hpp"

namespace hbp::cuda {

struct DeviceCell::State {
  int device = require_device();  // current when the engine was made: its calls run there
  cudaStream_t stream = nullptr;
  DeviceBuffer lanes, ids, counts, offsets, pairs, starts, regions;
  ~State() {
    const DeviceScope scope(device);
    if (stream) cudaStreamDestroy(stream);
  }
};

DeviceCell::DeviceCell() : state_(std::make_unique<State>()) {
  check_cuda(cudaStreamCreateWithFlags(&state_->stream, cudaStreamNonBlocking), "cudaStreamCreate");
}

DeviceCell::~DeviceCell() = default;

void DeviceCell::run(const CellSweep& sorted, const CellRegion& region, std::uint64_t pair_limit,
                     std::vector<Pair>& out) {
  const DeviceScope scope(state_->device);
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

void DeviceCell::run_batch(const CellBatch& batch, std::uint64_t pair_limit, std::vector<Pair>& out,
                           std::span<CellBatchOutcome> outcomes) {
  const DeviceScope scope(state_->device);
  State& st = *state_;
  const std::uint32_t cells = batch.cells();
  const std::uint32_t n = batch.starts[cells];
  const std::size_t base = out.size();
  for (CellBatchOutcome& o : outcomes) o = {base, {}};
  if (n < 2) return;
  const cudaStream_t s = st.stream;
  std::uint32_t largest = 0;
  for (std::uint32_t k = 0; k < cells; ++k) largest = std::max(largest, batch.starts[k + 1] - batch.starts[k]);
  if (iota_.size() < largest) {
    iota_.resize(largest);
    std::iota(iota_.begin(), iota_.end(), 0u);
  }
  st.lanes.reserve(std::size_t{6} * n * sizeof(float));
  st.ids.reserve(std::size_t{largest} * 4);
  st.counts.reserve(std::size_t{n} * 8);
  st.offsets.reserve(std::size_t{n} * 8);
  st.starts.reserve((std::size_t{cells} + 1) * 4);
  st.regions.reserve(std::size_t{cells} * sizeof(CellRegion));
  float* lanes = st.lanes.as<float>();
  const BoxArray& boxes = *batch.boxes;
  for (int l = 0; l < 6; ++l)
    check_cuda(cudaMemcpyAsync(lanes + static_cast<std::size_t>(l) * n, l < 3 ? boxes.min(l) : boxes.max(l - 3),
                               n * sizeof(float), cudaMemcpyHostToDevice, s),
               "batch upload");
  check_cuda(cudaMemcpyAsync(st.ids.as<std::uint32_t>(), iota_.data(), std::size_t{largest} * 4, cudaMemcpyHostToDevice, s),
             "ids upload");
  check_cuda(cudaMemcpyAsync(st.starts.as<std::uint32_t>(), batch.starts.data(), (std::size_t{cells} + 1) * 4,
                             cudaMemcpyHostToDevice, s),
             "starts upload");
  check_cuda(cudaMemcpyAsync(st.regions.as<CellRegion>(), batch.regions.data(), std::size_t{cells} * sizeof(CellRegion),
                             cudaMemcpyHostToDevice, s),
             "regions upload");
  const SortedLanes lanes_view{{lanes, lanes + n, lanes + 2 * std::size_t{n}},
                               {lanes + 3 * std::size_t{n}, lanes + 4 * std::size_t{n}, lanes + 5 * std::size_t{n}},
                               st.ids.as<std::uint32_t>()};
  launch_sorted_batch_rows(lanes_view, cells, st.starts.as<std::uint32_t>(), st.regions.as<CellRegion>(),
                           st.counts.as<std::uint64_t>(), nullptr, nullptr, s);
  counts_.resize(n);
  check_cuda(cudaMemcpyAsync(counts_.data(), st.counts.as<std::uint64_t>(), std::size_t{n} * 8, cudaMemcpyDeviceToHost, s),
             "counts");
  check_cuda(cudaStreamSynchronize(s), "batch count");
  // Rows in batch order are cells in order: the exclusive scan is every
  // row's offset in the batch's list, and each cell ends where the next
  // cell's first row starts.
  std::uint64_t total = 0;
  for (std::uint32_t k = 0; k < cells; ++k) {
    for (std::uint32_t r = batch.starts[k]; r < batch.starts[k + 1]; ++r) total += std::exchange(counts_[r], total);
    outcomes[k].end = base + total;
  }
  if (total > pair_limit)
    throw CapacityExceeded("cell batch of " + std::to_string(cells) + " cells has more than " +
                           std::to_string(pair_limit) + " overlapping pairs (max_pairs)");
  if (!total) return;
  st.pairs.reserve(total * 8);
  check_cuda(cudaMemcpyAsync(st.offsets.as<std::uint64_t>(), counts_.data(), std::size_t{n} * 8, cudaMemcpyHostToDevice, s),
             "offsets");
  launch_sorted_batch_rows(lanes_view, cells, st.starts.as<std::uint32_t>(), st.regions.as<CellRegion>(), nullptr,
                           st.offsets.as<std::uint64_t>(), st.pairs.as<std::uint32_t>(), s);
  out.resize(base + total);
  check_cuda(cudaMemcpyAsync(out.data() + base, st.pairs.as<std::uint32_t>(), total * 8, cudaMemcpyDeviceToHost, s),
             "pairs download");
  check_cuda(cudaStreamSynchronize(s), "batch fill");
}

}  // namespace hbp::cuda
