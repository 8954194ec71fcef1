// SPDX-License-Identifier: MIT
#pragma once
// Axis-aligned bounding box in float64 with closed intervals (touching faces
// overlap): the input of a double-precision BroadPhase
// (BroadPhaseOptions::double_precision), for worlds whose coordinates float32
// cannot resolve (at 1e7 one float step is 1).
#include <array>
#include <cmath>

namespace hbp {

struct AabbD {
  std::array<double, 3> min;
  std::array<double, 3> max;
};

// IEEE-754 comparisons, as overlaps(Aabb, Aabb); callers reject NaN first.
inline bool overlaps(const AabbD& a, const AabbD& b) {
  return a.max[0] >= b.min[0] && a.min[0] <= b.max[0] &&
         a.max[1] >= b.min[1] && a.min[1] <= b.max[1] &&
         a.max[2] >= b.min[2] && a.min[2] <= b.max[2];
}

// nullptr when the box is well formed, otherwise what is wrong (the strings
// of box_defect(Aabb)).
inline const char* box_defect(const AabbD& box) {
  for (int k = 0; k < 3; ++k) {
    if (std::isnan(box.min[k]) || std::isnan(box.max[k])) return "NaN coordinate";
    if (std::isinf(box.min[k]) || std::isinf(box.max[k])) return "infinite coordinate";
  }
  for (int k = 0; k < 3; ++k)
    if (box.min[k] > box.max[k]) return "min > max";
  return nullptr;
}

}  // namespace hbp
