#pragma once
// A shape prepared for the narrow phase: rotation matrix, half extents and
// bounding radius computed once, and the support mapping used by GJK/EPA and
// the libccd adapter.
#include <cmath>

#include "hbp/narrow/vec_math.hpp"
#include "hbp/shape.hpp"

namespace hbp::narrow {

struct Convex {
  ShapeKind kind = ShapeKind::Cuboid;
  double h[3] = {0, 0, 0};  // half extents along the local axes
  double r[3][3] = {};      // local-to-world rotation (column j = local axis j)
  V3 centre;
  double radius = 0;        // bounding-sphere radius about centre

  V3 axis(int j) const { return {r[0][j], r[1][j], r[2][j]}; }
  V3 to_local(const V3& w) const;  // rotation only (direction or offset)
  V3 to_world(const V3& l) const;  // rotation only
  // A point of the shape maximising dot(p, d) (world frame; d need not be unit).
  V3 support(const V3& d) const;
  // Ellipsoid with three equal semi-axes.
  bool is_true_sphere() const { return kind == ShapeKind::Sphere && h[0] == h[1] && h[1] == h[2]; }
};

Convex make_convex(const Shape& shape);
// Convex::radius without preparing the shape.
double bounding_radius(const Shape& shape);

// Tolerance scale of a pair: sum of the bounding radii.
inline double pair_scale(const Convex& a, const Convex& b) { return a.radius + b.radius; }

// Inline: GJK and EPA call these about twenty times per colliding pair.
inline V3 Convex::to_local(const V3& w) const {
  return {r[0][0] * w.x + r[1][0] * w.y + r[2][0] * w.z,
          r[0][1] * w.x + r[1][1] * w.y + r[2][1] * w.z,
          r[0][2] * w.x + r[1][2] * w.y + r[2][2] * w.z};
}

inline V3 Convex::to_world(const V3& l) const {
  return {r[0][0] * l.x + r[0][1] * l.y + r[0][2] * l.z,
          r[1][0] * l.x + r[1][1] * l.y + r[1][2] * l.z,
          r[2][0] * l.x + r[2][1] * l.y + r[2][2] * l.z};
}

// Support point in the shape's local frame for a local direction u.
inline V3 local_support(ShapeKind kind, const double h[3], const V3& u) {
  switch (kind) {
    case ShapeKind::Cuboid:
      return {std::copysign(h[0], u.x), std::copysign(h[1], u.y), std::copysign(h[2], u.z)};
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
      if (kind == ShapeKind::Cylinder) return {rx, ry, std::copysign(h[2], u.z)};
      // Cone: the apex (0, 0, +h) or a point of the base rim at z = -h.
      const double apex = h[2] * u.z;
      const double base = len - h[2] * u.z;
      if (apex >= base) return {0, 0, h[2]};
      return {rx, ry, -h[2]};
    }
  }
  return {};
}

inline V3 Convex::support(const V3& d) const {
  return centre + to_world(local_support(kind, h, to_local(d)));
}

}  // namespace hbp::narrow
