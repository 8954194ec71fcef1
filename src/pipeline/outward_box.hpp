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
#include <bit>
#include <cstdint>
#include <limits>

#include "hbp/aabb.hpp"
#include "hbp/aabb_d.hpp"

namespace hbp::detail {

// The float just above / below f (finite), without a libm call; past the
// largest float, infinity (an inward bound beyond float's range).
inline float float_above(float f) {
  if (f == 0.0f) return std::numeric_limits<float>::denorm_min();
  if (f == std::numeric_limits<float>::max()) return std::numeric_limits<float>::infinity();
  const auto bits = std::bit_cast<std::uint32_t>(f);
  return std::bit_cast<float>(f > 0.0f ? bits + 1 : bits - 1);
}
inline float float_below(float f) { return -float_above(-f); }

// The largest float <= x (x finite), clamped to [-FLT_MAX, FLT_MAX].
inline float round_down(double x) {
  constexpr float top = std::numeric_limits<float>::max();
  if (x >= static_cast<double>(top)) return top;
  if (x <= -static_cast<double>(top)) return -top;
  const float f = static_cast<float>(x);  // nearest
  return static_cast<double>(f) > x ? float_below(f) : f;
}
// The smallest float >= x (x finite), clamped to [-FLT_MAX, FLT_MAX].
inline float round_up(double x) { return -round_down(-x); }

// Writes b's outward float box (min rounded down, max rounded up) to out
// and its inward box (min up, max down: inside b; empty, min > max, when b
// is thinner than a float step on an axis; a bound beyond float's range is
// infinite there) to in; returns whether every
// coordinate was a float (then out == in == b). When the inward boxes of
// two objects overlap their double boxes do: most true pairs are confirmed
// from these 24 bytes an object, and only pairs within a float step of
// touching need the doubles.
inline bool round_box(const AabbD& b, Aabb& out, Aabb& in) {
  bool exact = true;
  for (int k = 0; k < 3; ++k) {
    const float lo = round_down(b.min[k]), hi = round_up(b.max[k]);
    const bool lo_exact = static_cast<double>(lo) == b.min[k], hi_exact = static_cast<double>(hi) == b.max[k];
    out.min[k] = lo;
    out.max[k] = hi;
    in.min[k] = lo_exact ? lo : float_above(lo);
    in.max[k] = hi_exact ? hi : float_below(hi);
    exact &= lo_exact & hi_exact;
  }
  return exact;
}

// The outward box alone (queries).
inline Aabb outward_box(const AabbD& b) {
  Aabb out, in;
  round_box(b, out, in);
  return out;
}

}  // namespace hbp::detail
