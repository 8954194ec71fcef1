// SPDX-License-Identifier: MIT
#pragma once
// One cell through the accelerator kernel on a CUDA device (the "cuda" cell
// engine): the cell's sorted lanes uploaded, a thread block sweeping it with
// its boxes in shared memory, counted, scanned on the host, checked against
// the pair limit, then filled and downloaded. Device buffers grow and are
// kept across calls.
#include <cstdint>
#include <memory>
#include <span>
#include <vector>

#include "cuda/cell_sweep.hpp"
#include "hbp/cell_engine.hpp"
#include "hbp/cell_region.hpp"
#include "hbp/pair.hpp"

namespace hbp::cuda {

class DeviceCell {
 public:
  DeviceCell();  // hbp::Error "no CUDA device found" when none
  ~DeviceCell();
  DeviceCell(const DeviceCell&) = delete;
  DeviceCell& operator=(const DeviceCell&) = delete;
  // Appends the owned pairs of the cell `sorted` holds (CellSweep::sort).
  void run(const CellSweep& sorted, const CellRegion& region, std::uint64_t pair_limit, std::vector<Pair>& out);
  // A batch of cells, each already in min-x order (CellEngine::
  // find_owned_pairs_batch): one upload, one counting launch, one scan on
  // the host, one filling launch and one download for the whole batch.
  // CapacityExceeded when the batch has more than `pair_limit` pairs,
  // before any is appended.
  void run_batch(const CellBatch& batch, std::uint64_t pair_limit, std::vector<Pair>& out,
                 std::span<CellBatchOutcome> outcomes);

 private:
  struct State;
  std::unique_ptr<State> state_;
  std::vector<std::uint64_t> counts_;
  std::vector<std::uint32_t> iota_;
};

}  // namespace hbp::cuda
