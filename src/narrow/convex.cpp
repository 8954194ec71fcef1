#include "hbp/narrow/convex.hpp"

#include <cmath>

namespace hbp::narrow {

double bounding_radius(const Shape& shape) {
  const double hx = 0.5 * shape.size.x, hy = 0.5 * shape.size.y, hz = 0.5 * shape.size.z;
  switch (shape.kind) {
    case ShapeKind::Sphere: return std::fmax(hx, std::fmax(hy, hz));
    case ShapeKind::Cuboid: return std::sqrt(hx * hx + hy * hy + hz * hz);
    case ShapeKind::Cylinder:
    case ShapeKind::Cone: return std::sqrt(std::fmax(hx * hx, hy * hy) + hz * hz);
  }
  return 0;
}

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
