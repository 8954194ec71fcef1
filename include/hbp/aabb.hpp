// SPDX-License-Identifier: MIT
#pragma once
// Axis-aligned bounding box in float32 with closed intervals: touching faces
// overlap. This is the one overlap rule of the whole system (software engines,
// hardware models, RTL, baselines after filtering).
#include <cstdint>

namespace hbp {

struct Aabb {
  float min[3];
  float max[3];
};

// IEEE-754 comparisons, so -0 == +0; callers reject NaN before this point.
inline bool overlaps(const Aabb& a, const Aabb& b) {
  return a.max[0] >= b.min[0] && a.min[0] <= b.max[0] &&
         a.max[1] >= b.min[1] && a.min[1] <= b.max[1] &&
         a.max[2] >= b.min[2] && a.min[2] <= b.max[2];
}

// Returns nullptr when the box is well formed, otherwise a static string
// saying what is wrong ("NaN coordinate", "infinite coordinate", "min > max").
const char* box_defect(const Aabb& box);

}  // namespace hbp
