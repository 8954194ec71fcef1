// SPDX-License-Identifier: MIT
#pragma once
// The launchers of AxisSweep share this base and the axis rule.
#include <cstdint>
#include <memory>
#include <vector>

#include "hbp/cuda/axis_sweep.hpp"

namespace hbp::cuda {

struct AxisSweep::Impl {
  explicit Impl(const FrameOptions& o) : options(o) {}
  virtual ~Impl() = default;
  virtual void run(const Lanes& boxes) = 0;
  FrameOptions options;
  FrameInfo info;
  std::vector<Pair> pairs;
  int axis = 0;
};

std::unique_ptr<AxisSweep::Impl> make_host_axis_sweep(const FrameOptions& options);
std::unique_ptr<AxisSweep::Impl> make_device_axis_sweep(const FrameOptions& options);

// The axis of largest variance of the centres (min + max, the factor 1/2
// left out), from per-axis sums and sums of squares; the first on ties.
inline int largest_variance_axis(const double sum[3], const double sum_sq[3], std::uint32_t n) {
  int best = 0;
  double best_var = -1;
  for (int k = 0; k < 3; ++k) {
    const double mean = n ? sum[k] / n : 0;
    const double var = n ? sum_sq[k] / n - mean * mean : 0;
    if (var > best_var) {
      best_var = var;
      best = k;
    }
  }
  return best;
}

}  // namespace hbp::cuda
