// SPDX-License-Identifier: MIT
#pragma once
// The paper's GPU column's algorithm as a peer (Bullet3's
// b3GpuSapBroadphase): sort the boxes by min on the axis along which their
// centres vary most, then a thread per box sweeping forward until a box
// starts past its max, testing the other two axes. Exact here (closed
// intervals, each pair once, counted before written so none is dropped and
// max_pairs gives CapacityExceeded), on the CPU launcher or a CUDA device,
// with the frame's options and stage times (FrameInfo: refs/cells are 0;
// sort_ms holds axis choice and sort, count_ms and fill_ms the sweeps).
#include <memory>
#include <vector>

#include "hbp/cuda/frame_broadphase.hpp"

namespace hbp::cuda {

class AxisSweep {
 public:
  explicit AxisSweep(const FrameOptions& options = {});  // Device: "no CUDA device found" when none
  ~AxisSweep();
  AxisSweep(AxisSweep&&) noexcept;
  AxisSweep& operator=(AxisSweep&&) noexcept;
  const std::vector<Pair>& update(const Lanes& boxes);
  const FrameInfo& info() const;
  // The sweep axis of the last frame (0, 1, 2).
  int axis() const;

  struct Impl;

 private:
  std::unique_ptr<Impl> impl_;
};

}  // namespace hbp::cuda
