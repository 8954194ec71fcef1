// SPDX-License-Identifier: MIT
#pragma once
// One cell through the accelerator kernel on a CUDA device (the "cuda" cell
// engine): the cell's sorted lanes uploaded, a thread block sweeping it with
// its boxes in shared memory, counted, scanned on the host, checked against
// the pair limit, then filled and downloaded. Device buffers grow and are
// kept across calls.
#include <cstdint>
#include <memory>
#include <vector>

#include "cuda/cell_sweep.hpp"
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

 private:
  struct State;
  std::unique_ptr<State> state_;
  std::vector<std::uint64_t> counts_;
};

}  // namespace hbp::cuda
