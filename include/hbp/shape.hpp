// SPDX-License-Identifier: MIT
#pragma once
// The paper's four shapes with a size per axis, a position and an orientation,
// and the exact tight world AABB of each under any rotation.
//
// Local frames (all centred on `position`):
//  - Sphere:   ellipsoid with semi-axes size/2.
//  - Cuboid:   box with half extents size/2.
//  - Cylinder: axis along local z, height size.z, elliptic cross-section with
//              diameters size.x, size.y.
//  - Cone:     axis along local z, apex at z = +size.z/2, elliptic base of
//              diameters size.x, size.y at z = -size.z/2.
#include <cstdint>

#include "hbp/aabb.hpp"

namespace hbp {

enum class ShapeKind : std::uint8_t { Sphere = 0, Cuboid = 1, Cylinder = 2, Cone = 3 };
inline constexpr int kShapeKindCount = 4;
const char* shape_kind_name(ShapeKind kind);

struct Vec3 {
  double x = 0, y = 0, z = 0;
  double operator[](int i) const { return i == 0 ? x : (i == 1 ? y : z); }
};

// Unit quaternion (w, x, y, z).
struct Quat {
  double w = 1, x = 0, y = 0, z = 0;
};

// Row-major 3x3 rotation matrix of a unit quaternion (maps local to world).
void rotation_matrix(const Quat& q, double r[3][3]);
Quat normalized(const Quat& q);
Quat multiply(const Quat& a, const Quat& b);
// q advanced by angular velocity w (rad/s, world frame) over dt seconds.
Quat integrate_rotation(const Quat& q, const Vec3& w, double dt);

struct Shape {
  ShapeKind kind = ShapeKind::Cuboid;
  Vec3 size;  // full extent per local axis (metres)
  Vec3 position;
  Quat orientation;
};

// Tight AABB computed in double from closed forms (support functions of each
// shape along the world axes), then rounded outward to float32 so the box
// always contains the shape.
Aabb tight_aabb(const Shape& shape);

// Support point of the shape in world direction d (for tests and the narrow
// phase): a point of the shape maximising dot(p, d).
Vec3 support_point(const Shape& shape, const Vec3& d);

}  // namespace hbp
