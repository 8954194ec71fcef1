#pragma once
// A shape prepared for the narrow phase: rotation matrix, half extents and
// bounding radius computed once, and the support mapping used by GJK/EPA and
// the libccd adapter.
#include <algorithm>
#include <cmath>

#include "hbp/narrow/vec_math.hpp"
#include "hbp/shape.hpp"

namespace hbp::narrow {

// No default member initialisers on the arrays: make_convex writes every
// field, and zeroing 200 bytes per shape (a `rep stos`) cost more than the
// rest of make_convex at 100,000 objects.
struct Convex {
  ShapeKind kind = ShapeKind::Cuboid;
  double h[3];              // half extents along the local axes
  double r[3][3];           // local-to-world rotation (column j = local axis j)
  V3 centre;
  double radius = 0;        // bounding-sphere radius about centre
  // r with column j scaled by h[j]: maps the shape's unit frame (unit ball,
  // cube [-1, 1]^3, unit cylinder / cone) to the world. The support mapping
  // works there: u = m^T d, p = centre + m q(u), no scaling by h.
  double m[3][3];

  V3 axis(int j) const { return {r[0][j], r[1][j], r[2][j]}; }
  V3 to_local(const V3& w) const;  // rotation only (direction or offset)
  V3 to_world(const V3& l) const;  // rotation only
  // A point of the shape maximising dot(p, d) (world frame; d need not be unit).
  V3 support(const V3& d) const;
  // Ellipsoid with three equal semi-axes.
  bool is_true_sphere() const { return kind == ShapeKind::Sphere && h[0] == h[1] && h[1] == h[2]; }
};

Convex make_convex(const Shape& shape);
// The same with its bounding radius already computed (bounding_radius).
Convex make_convex(const Shape& shape, double radius);
// Convex::radius without preparing the shape (inline: the narrow phase's
// first test on every candidate pair).
inline double bounding_radius(const Shape& shape) {
  const double hx = 0.5 * shape.size.x, hy = 0.5 * shape.size.y, hz = 0.5 * shape.size.z;
  switch (shape.kind) {
    case ShapeKind::Sphere: return std::max(hx, std::max(hy, hz));  // std::fmax is a libm call here
    case ShapeKind::Cuboid: return std::sqrt(hx * hx + hy * hy + hz * hz);
    case ShapeKind::Cylinder:
    case ShapeKind::Cone: return std::sqrt(std::max(hx * hx, hy * hy) + hz * hz);
  }
  return 0;
}

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

// The support point in the unit frame: the direction there is u = m^T d
// (for the ellipsoid A^2 u / |A u| of the local frame becomes u / |u|).
// Same points as local_support up to rounding.
inline V3 Convex::support(const V3& d) const {
  const double ux = m[0][0] * d.x + m[1][0] * d.y + m[2][0] * d.z;
  const double uy = m[0][1] * d.x + m[1][1] * d.y + m[2][1] * d.z;
  const double uz = m[0][2] * d.x + m[1][2] * d.y + m[2][2] * d.z;
  double qx, qy, qz;
  switch (kind) {
    case ShapeKind::Cuboid:
      qx = ux >= 0 ? 1 : -1;
      qy = uy >= 0 ? 1 : -1;
      qz = uz >= 0 ? 1 : -1;
      break;
    case ShapeKind::Sphere: {
      const double len2 = ux * ux + uy * uy + uz * uz;
      if (len2 == 0) {
        qx = qy = 0;
        qz = 1;
        break;
      }
      const double inv = 1 / std::sqrt(len2);
      qx = ux * inv;
      qy = uy * inv;
      qz = uz * inv;
      break;
    }
    default: {  // cylinder, cone: the rim point of the unit section
      const double len = std::sqrt(ux * ux + uy * uy);
      const double inv = len == 0 ? 0 : 1 / len;
      qx = ux * inv;
      qy = uy * inv;
      qz = uz >= 0 ? 1 : -1;
      // Cone: the apex (0, 0, 1) or a point of the base rim at z = -1.
      if (kind == ShapeKind::Cone) {
        if (uz >= len - uz) {
          qx = qy = 0;
          qz = 1;
        } else {
          qz = -1;
        }
      }
      break;
    }
  }
  return {centre.x + m[0][0] * qx + m[0][1] * qy + m[0][2] * qz,
          centre.y + m[1][0] * qx + m[1][1] * qy + m[1][2] * qz,
          centre.z + m[2][0] * qx + m[2][1] * qy + m[2][2] * qz};
}

}  // namespace hbp::narrow
