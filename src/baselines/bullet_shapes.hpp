// SPDX-License-Identifier: MIT
#pragma once
// hbp shapes as Bullet convex shapes (mapping in bullet_shape_pair_test.hpp),
// shared by the pair test and the narrow-phase baseline.
#include <memory>

#include "hbp/shape.hpp"

#include "hbp/bullet/bullet_headers.hpp"

namespace hbp::baselines {

// Owns the Bullet objects that make up one hbp shape (zero margins).
struct BulletShape {
  std::unique_ptr<btConvexShape> child;
  std::unique_ptr<btConvexShape> outer;  // per-axis scale wrapper, if any
  const btConvexShape* shape() const { return outer ? outer.get() : child.get(); }
  btConvexShape* shape() { return outer ? outer.get() : child.get(); }
};

BulletShape make_bullet_shape(const Shape& s);
btTransform make_transform(const Shape& s);

}  // namespace hbp::baselines
