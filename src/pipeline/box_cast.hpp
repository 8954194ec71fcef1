// SPDX-License-Identifier: MIT
#pragma once
// A box swept along a displacement and its test against a target box: the
// one box-cast rule of BroadPhase::query_box_cast (the tree walk and the
// brute-force reference in the tests use this arithmetic).
//
// The moving box B + t * d, 0 <= t <= 1, touches the closed box T iff on
// every axis t * d lies in [T.min - B.max, T.max - B.min]: the segment from
// the origin along d, max_t 1, against T grown by B (the Minkowski sum),
// tested by RaySegment's slab rule. Each grown bound is one float
// subtraction (rounded to nearest); its sign is exact, so on an axis where
// d is 0 the test is exactly the closed overlap of B and T, and with d = 0
// the cast is query_box(B). Rounding is monotone, so a box containing T
// gives a grown box containing T's: the tree's conservative node test
// passes whenever an object below it would.
#include "hbp/aabb.hpp"
#include "pipeline/ray_segment.hpp"

namespace hbp::detail {

struct BoxCast {
  Aabb box;         // the moving box at t = 0
  RaySegment ray;   // origin 0, direction d, max_t 1

  BoxCast(const Aabb& b, const float displacement[3]) : box(b), ray(kZero, displacement, 1.0f) {}

  // Whether the moving box touches [mn, mx] at some t in [0, 1]; `entry` is
  // the first such t (0 when they overlap at the start).
  bool hits(const float mn[3], const float mx[3], float& entry) const {
    float gmn[3], gmx[3];
    for (int k = 0; k < 3; ++k) {
      gmn[k] = mn[k] - box.max[k];
      gmx[k] = mx[k] - box.min[k];
    }
    return ray.hits(gmn, gmx, entry);
  }

 private:
  static constexpr float kZero[3] = {0.0f, 0.0f, 0.0f};
};

}  // namespace hbp::detail
