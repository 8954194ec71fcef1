// SPDX-License-Identifier: MIT
#include <cmath>

#include "hbp/narrow/closed_forms.hpp"

namespace hbp::narrow {

bool sphere_sphere(const Convex& a, const Convex& b, Hit* hit) {
  const double ra = a.h[0], rb = b.h[0];
  const V3 d = b.centre - a.centre;
  const double d2 = norm2(d);
  const double sum = ra + rb;
  if (d2 > sum * sum) return false;
  if (hit) {
    const double dist = std::sqrt(d2);
    hit->normal = dist > 0 ? d * (1.0 / dist) : V3{0, 0, 1};
    hit->depth = sum - dist;
    // Midway between the deepest points a.centre + n ra and b.centre - n rb.
    hit->point = 0.5 * ((a.centre + hit->normal * ra) + (b.centre - hit->normal * rb));
  }
  return true;
}

}  // namespace hbp::narrow
