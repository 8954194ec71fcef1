#pragma once
// A shape prepared for the narrow phase: rotation matrix, half extents and
// bounding radius computed once, and the support mapping used by GJK/EPA and
// the libccd adapter.
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

// Support point in the shape's local frame for a local direction u.
V3 local_support(ShapeKind kind, const double h[3], const V3& u);

}  // namespace hbp::narrow
