// SPDX-License-Identifier: MIT
#pragma once
// Closed-form tests, cheaper than GJK/EPA where they apply:
//  - true sphere vs true sphere (all three semi-axes equal),
//  - cuboid vs true sphere (closest point on the box),
//  - cuboid vs cuboid (separating-axis test on the 15 candidate axes; the
//    smallest overlap over those axes is the exact penetration depth).
// Touching shapes (distance exactly 0) count as intersecting. Each returns
// whether the shapes intersect and, if hit is non-null, fills it.
#include "hbp/narrow/convex.hpp"
#include "hbp/narrow/hit.hpp"

namespace hbp::narrow {

bool sphere_sphere(const Convex& a, const Convex& b, Hit* hit);
bool box_sphere(const Convex& box, const Convex& sphere, Hit* hit);  // normal box -> sphere
bool box_box(const Convex& a, const Convex& b, Hit* hit);

}  // namespace hbp::narrow
