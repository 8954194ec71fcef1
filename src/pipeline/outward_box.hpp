// SPDX-License-Identifier: MIT
#pragma once
// The float32 box a double-precision BroadPhase gives its float engine for a
// double box: each min rounded down, each max rounded up to a float, clamped
// to the finite floats. Rounding is monotone, so whenever two double boxes
// overlap their outward boxes overlap too: the float engine finds every true
// pair (plus pairs that only the rounding made touch, which the double
// confirmation drops). When every coordinate was a float already the outward
// box is the box itself and its float test is exact. The inward box (below)
// settles most of the other candidates without the doubles.
#include <cmath>
#include <cstdint>
#include <limits>

#include "hbp/aabb.hpp"
#include "hbp/aabb_d.hpp"

namespace hbp::detail {

// The largest float <= x (x finite), at least -FLT_MAX and at most FLT_MAX.
inline float round_down(double x) {
  constexpr float top = std::numeric_limits<float>::max();
  if (x >= static_cast<double>(top)) return top;
  if (x <= -static_cast<double>(top)) return -top;
  float f = static_cast<float>(x);  // nearest
  if (static_cast<double>(f) > x) f = std::nextafter(f, -top);
  return f;
}
// The smallest float >= x (x finite), at least -FLT_MAX and at most FLT_MAX.
inline float round_up(double x) { return -round_down(-x); }

// Writes b's outward float box to out; returns whether it equals b exactly.
inline bool outward_box(const AabbD& b, Aabb& out) {
  bool exact = true;
  for (int k = 0; k < 3; ++k) {
    out.min[k] = round_down(b.min[k]);
    out.max[k] = round_up(b.max[k]);
    exact &= (static_cast<double>(out.min[k]) == b.min[k]) & (static_cast<double>(out.max[k]) == b.max[k]);
  }
  return exact;
}

// b's inward float box: each min rounded up, each max rounded down (empty,
// min > max, when b is thinner than a float step on an axis). It lies
// inside b, so when the inward boxes of two objects overlap their double
// boxes do: most true pairs are confirmed from these 24 bytes an object,
// and only pairs within a float step of touching need the double boxes.
inline Aabb inward_box(const AabbD& b) {
  Aabb in;
  for (int k = 0; k < 3; ++k) {
    in.min[k] = round_up(b.min[k]);
    in.max[k] = round_down(b.max[k]);
  }
  return in;
}

}  // namespace hbp::detail
