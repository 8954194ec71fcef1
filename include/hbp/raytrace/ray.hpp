// SPDX-License-Identifier: MIT
#pragma once
// A ray and the closest hit the ray tracer reports. Double precision: the
// shape tests are exact closed forms (see ray_shape.hpp).
#include <cstdint>

namespace hbp {

struct Ray {
  double origin[3];
  double dir[3];   // need not be unit length; t is in units of |dir|
  double tmin = 0;  // hits count when tmin <= t <= tmax
  double tmax = 1e300;
};

struct RayHit {
  static constexpr std::uint32_t kNone = 0xFFFFFFFFu;
  double t = 0;
  std::uint32_t object = kNone;
  std::uint8_t part = 0;  // which surface of the shape (see ray_shape.hpp)
  bool hit() const { return object != kNone; }
};

// Closest-hit order: smaller t first, then smaller object id (ties are exact
// since every path runs the same shape test).
inline bool closer(double t, std::uint32_t object, const RayHit& than) {
  return t < than.t || (t == than.t && object < than.object);
}

}  // namespace hbp
