// SPDX-License-Identifier: MIT
#pragma once
// The box screen: the one test of well-formed boxes on the library's hot
// paths (every coordinate finite, min <= max on each axis). When a screen
// fails, box_defect (hbp/aabb.hpp) names the first bad box and its defect.
//
// Written so that GCC vectorises it: x - x == 0 exactly when x is finite
// (NaN and +-inf give NaN, which fails every comparison), and the failures
// are OR-ed as ints (a bool AND of the passes compiled to scalar compares
// and branches, ~60 instructions a box).
#include <cstddef>

#include "hbp/aabb.hpp"
#include "hbp/box_array.hpp"
#include "hbp/host_device.hpp"

namespace hbp::geometry {

// Non-zero when [lo, hi] is not a finite interval with lo <= hi (host and
// device: the GPU frame screens its boxes with it too).
HBP_HOST_DEVICE inline int interval_fails(float lo, float hi) { return !(lo - lo == 0.0f) | !(hi - hi == 0.0f) | !(lo <= hi); }

// True when some box of [begin, end) is not well formed.
inline bool screen_fails(const BoxArray& boxes, std::size_t begin, std::size_t end) {
  int bad = 0;
  for (int k = 0; k < 3; ++k) {
    const float* lo = boxes.min(k);
    const float* hi = boxes.max(k);
    for (std::size_t i = begin; i != end; ++i) bad |= interval_fails(lo[i], hi[i]);
  }
  return bad != 0;
}

inline bool screen_fails(const Aabb* boxes, std::size_t begin, std::size_t end) {
  int bad = 0;
  for (std::size_t i = begin; i != end; ++i)
    for (int k = 0; k < 3; ++k) bad |= interval_fails(boxes[i].min[k], boxes[i].max[k]);
  return bad != 0;
}

}  // namespace hbp::geometry
