// SPDX-License-Identifier: MIT
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
  // Ellipsoids only: the support mapping of the shape's core, the shape
  // shrunk by a ball of this radius (at most core_radius(*this)): the core
  // plus that ball is the shape again. 0: the shape itself.
  double core_inset = 0;

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

// The radius of the largest ball that rolls freely inside the shape (the
// smallest radius of curvature of its surface): for an ellipsoid with
// semi-axes a >= b >= c it is c^2 / a (a true sphere: its radius, the core
// is its centre); a cuboid, cylinder or cone has corners or rims: 0.
inline double core_radius(const Convex& c) {
  if (c.kind != ShapeKind::Sphere) return 0;
  const double lo = std::min(c.h[0], std::min(c.h[1], c.h[2])), hi = std::max(c.h[0], std::max(c.h[1], c.h[2]));
  return hi > 0 ? lo * lo / hi : 0;
}

// The shape's core: the same shape with the support mapping moved in by
// core_radius (a shape with rims or corners is its own core).
inline Convex core_of(const Convex& c) {
  Convex core = c;
  core.core_inset = core_radius(c);
  return core;
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

// The support point in the unit frame: the direction there is u = m^T d
// (for the ellipsoid A^2 u / |A u| of the local frame becomes u / |u|).
// Box corner and cylinder cap signs by copysign, not a branch: the signs
// are unpredictable (EPA on the paper scene's colliding pairs about 7 %
// less CPU); a zero component may pick either end, both support points.
inline V3 Convex::support(const V3& d) const {
  const double ux = m[0][0] * d.x + m[1][0] * d.y + m[2][0] * d.z;
  const double uy = m[0][1] * d.x + m[1][1] * d.y + m[2][1] * d.z;
  const double uz = m[0][2] * d.x + m[1][2] * d.y + m[2][2] * d.z;
  double qx, qy, qz;
  switch (kind) {
    case ShapeKind::Cuboid:
      qx = std::copysign(1.0, ux);
      qy = std::copysign(1.0, uy);
      qz = std::copysign(1.0, uz);
      break;
    case ShapeKind::Sphere: {
      const double len2 = ux * ux + uy * uy + uz * uz;
      if (len2 == 0) {
        if (core_inset != 0) return centre;  // any point of the core
        qx = qy = 0;
        qz = 1;
        break;
      }
      const double inv = 1 / std::sqrt(len2);
      qx = ux * inv;
      qy = uy * inv;
      qz = uz * inv;
      if (core_inset != 0) {
        // The core's support point: the shape's, moved in by the inset
        // along the unit direction (d != 0 here: u = m^T d is not zero).
        const double shift = core_inset / std::sqrt(d.x * d.x + d.y * d.y + d.z * d.z);
        return {centre.x + m[0][0] * qx + m[0][1] * qy + m[0][2] * qz - shift * d.x,
                centre.y + m[1][0] * qx + m[1][1] * qy + m[1][2] * qz - shift * d.y,
                centre.z + m[2][0] * qx + m[2][1] * qy + m[2][2] * qz - shift * d.z};
      }
      break;
    }
    default: {  // cylinder, cone: the rim point of the unit section
      const double len = std::sqrt(ux * ux + uy * uy);
      const double inv = len == 0 ? 0 : 1 / len;
      qx = ux * inv;
      qy = uy * inv;
      qz = std::copysign(1.0, uz);
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
