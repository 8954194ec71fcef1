#include "hbp/narrow/convex.hpp"

#include <cmath>

namespace hbp::narrow {

V3 Convex::to_local(const V3& w) const {
  return {r[0][0] * w.x + r[1][0] * w.y + r[2][0] * w.z,
          r[0][1] * w.x + r[1][1] * w.y + r[2][1] * w.z,
          r[0][2] * w.x + r[1][2] * w.y + r[2][2] * w.z};
}

V3 Convex::to_world(const V3& l) const {
  return {r[0][0] * l.x + r[0][1] * l.y + r[0][2] * l.z,
          r[1][0] * l.x + r[1][1] * l.y + r[1][2] * l.z,
          r[2][0] * l.x + r[2][1] * l.y + r[2][2] * l.z};
}

V3 local_support(ShapeKind kind, const double h[3], const V3& u) {
  switch (kind) {
    case ShapeKind::Cuboid:
      return {u.x >= 0 ? h[0] : -h[0], u.y >= 0 ? h[1] : -h[1], u.z >= 0 ? h[2] : -h[2]};
    case ShapeKind::Sphere: {
      // Ellipsoid x^2/a^2 + ... = 1: the support point is A^2 u / |A u|.
      const V3 s{h[0] * u.x, h[1] * u.y, h[2] * u.z};
      const double len = norm(s);
      if (len == 0) return {0, 0, h[2]};
      return {h[0] * s.x / len, h[1] * s.y / len, h[2] * s.z / len};
    }
    case ShapeKind::Cylinder:
    case ShapeKind::Cone: {
      // Rim point of the elliptic section that maximises the in-plane part.
      const double sx = h[0] * u.x, sy = h[1] * u.y;
      const double len = std::sqrt(sx * sx + sy * sy);
      const double rx = len == 0 ? 0 : h[0] * sx / len;
      const double ry = len == 0 ? 0 : h[1] * sy / len;
      if (kind == ShapeKind::Cylinder) return {rx, ry, u.z >= 0 ? h[2] : -h[2]};
      // Cone: the apex (0, 0, +h) or a point of the base rim at z = -h.
      const double apex = h[2] * u.z;
      const double base = len - h[2] * u.z;
      if (apex >= base) return {0, 0, h[2]};
      return {rx, ry, -h[2]};
    }
  }
  return {};
}

V3 Convex::support(const V3& d) const {
  return centre + to_world(local_support(kind, h, to_local(d)));
}

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

Convex make_convex(const Shape& shape) {
  Convex c;
  c.kind = shape.kind;
  c.h[0] = 0.5 * shape.size.x;
  c.h[1] = 0.5 * shape.size.y;
  c.h[2] = 0.5 * shape.size.z;
  rotation_matrix(normalized(shape.orientation), c.r);
  c.centre = to_v3(shape.position);
  c.radius = bounding_radius(shape);
  return c;
}

}  // namespace hbp::narrow
