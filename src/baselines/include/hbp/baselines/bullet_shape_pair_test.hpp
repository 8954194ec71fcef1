// SPDX-License-Identifier: MIT
#pragma once
// Independent reference for the narrow phase: Bullet's own GJK/EPA
// (btGjkEpaSolver2, single precision) on Bullet's own primitives with zero
// collision margins.
//
// Shape mapping (hbp -> Bullet):
//   cuboid                      btBoxShape(half extents)
//   cylinder, circular section  btCylinderShapeZ(r, r, h/2)
//   cone, circular base         btConeShapeZ(r, h) (apex at +h/2, as ours)
//   sphere (ellipsoid)          btSphereShape(1) scaled per axis
//   elliptic cylinder / cone    btCylinderShapeZ(1, 1, h/2) / btConeShapeZ(1, h)
//                               scaled by (a, b, 1)
// Bullet's local scaling of cylinders and cones stays circular, so the
// per-axis scale is applied by a small btConvexInternalShape wrapper whose
// support mapping is S * s_child(S * d) (exact for any linear scaling S).
#include "hbp/shape.hpp"

namespace hbp::baselines {

struct BulletPairResult {
  bool intersecting = false;
  // Separated: distance (> 0). Intersecting: minus the penetration depth.
  double signed_distance = 0;
  Vec3 normal;          // Bullet's contact normal, turned to point from a to b
  bool failed = false;  // GJK or EPA reported failure (status GJK_Failed / EPA_Failed)
};

BulletPairResult bullet_shape_pair_test(const Shape& a, const Shape& b);

// Bullet's support point of shape s in world direction d (checks the mapping).
Vec3 bullet_support_point(const Shape& s, const Vec3& d);

}  // namespace hbp::baselines
