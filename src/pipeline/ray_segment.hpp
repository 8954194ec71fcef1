// SPDX-License-Identifier: MIT
#pragma once
// The segment origin + t * direction, 0 <= t <= max_t, and its closed slab
// test against a box: the one ray/box rule of BroadPhase::query_ray (the
// tree walk and the brute-force reference in the tests use this arithmetic).
#include <algorithm>
#include <cmath>

namespace hbp::detail {

struct RaySegment {
  float origin[3];
  float inverse[3];   // 1 / direction; unused on parallel axes
  bool parallel[3];   // direction component 0 (or 1 / it overflows)
  float max_t;

  RaySegment(const float o[3], const float d[3], float t_max) : max_t(t_max) {
    for (int k = 0; k < 3; ++k) {
      origin[k] = o[k];
      inverse[k] = 1.0f / d[k];
      // A direction so small its inverse is infinite moves < 1e-38 per unit
      // t along that axis: treated as parallel (no inf * 0 = NaN).
      parallel[k] = d[k] == 0.0f || std::isinf(inverse[k]);
    }
  }

  // Whether the segment touches the closed box [mn, mx]; `entry` is the
  // first t inside it (0 when the origin is inside).
  bool hits(const float mn[3], const float mx[3], float& entry) const {
    float t0 = 0.0f, t1 = max_t;
    for (int k = 0; k < 3; ++k) {
      if (parallel[k]) {
        if (origin[k] < mn[k] || origin[k] > mx[k]) return false;
        continue;
      }
      float a = (mn[k] - origin[k]) * inverse[k];
      float b = (mx[k] - origin[k]) * inverse[k];
      if (a > b) std::swap(a, b);
      t0 = std::max(t0, a);
      t1 = std::min(t1, b);
    }
    if (!(t0 <= t1)) return false;
    entry = t0;
    return true;
  }
};

}  // namespace hbp::detail
