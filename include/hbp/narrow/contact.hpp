// SPDX-License-Identifier: MIT
#pragma once
// One colliding pair as the narrow phase reports it.
#include <cstdint>

#include "hbp/shape.hpp"

namespace hbp {

struct Contact {
  std::uint32_t a = 0, b = 0;  // object ids (a < b when produced from a Pair)
  // Unit contact normal pointing from a towards b: translating b by
  // normal * depth separates the shapes (they are then touching).
  Vec3 normal;
  double depth = 0;  // penetration depth (minimum translation distance), >= 0
  // A point midway between the deepest points of a and b (the EPA witnesses,
  // or the closed form's closest features).
  Vec3 point;
};

}  // namespace hbp
