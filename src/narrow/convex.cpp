// SPDX-License-Identifier: MIT
#include "hbp/narrow/convex.hpp"

#include <cmath>

namespace hbp::narrow {

Convex make_convex(const Shape& shape) { return make_convex(shape, bounding_radius(shape)); }

Convex make_convex(const Shape& shape, double radius) {
  Convex c;
  c.kind = shape.kind;
  c.h[0] = 0.5 * shape.size.x;
  c.h[1] = 0.5 * shape.size.y;
  c.h[2] = 0.5 * shape.size.z;
  rotation_matrix(normalized(shape.orientation), c.r);
  for (int i = 0; i < 3; ++i)
    for (int j = 0; j < 3; ++j) c.m[i][j] = c.r[i][j] * c.h[j];
  c.centre = to_v3(shape.position);
  c.radius = radius;
  return c;
}

}  // namespace hbp::narrow
