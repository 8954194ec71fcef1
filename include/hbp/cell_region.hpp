// SPDX-License-Identifier: MIT
#pragma once
// The half-open region [lo, hi) of one partition cell. A pair found in several
// cells is kept only in the cell whose region holds the pair's ownership
// point max(min_a, min_b) (the minimum corner of the two boxes' intersection),
// so every overlapping pair is reported exactly once without a global set.
// contains() is constexpr and host/device: the CUDA kernels test the same
// comparisons as the CPU (hbp/host_device.hpp).
#include <limits>

#include "hbp/host_device.hpp"

namespace hbp {

struct CellRegion {
  float lo[3];
  float hi[3];

  static CellRegion everything() {
    const float inf = std::numeric_limits<float>::infinity();
    return {{-inf, -inf, -inf}, {inf, inf, inf}};
  }
  HBP_HOST_DEVICE constexpr bool contains(float x, float y, float z) const {
    return x >= lo[0] && x < hi[0] && y >= lo[1] && y < hi[1] && z >= lo[2] && z < hi[2];
  }
};

}  // namespace hbp
