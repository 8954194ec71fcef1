// SPDX-License-Identifier: MIT
#include <cmath>

#include "hbp/narrow/closed_forms.hpp"

namespace hbp::narrow {

bool box_sphere(const Convex& box, const Convex& sphere, Hit* hit) {
  const double r = sphere.h[0];
  const V3 c = box.to_local(sphere.centre - box.centre);
  const V3 q{std::fmax(-box.h[0], std::fmin(box.h[0], c.x)), std::fmax(-box.h[1], std::fmin(box.h[1], c.y)),
             std::fmax(-box.h[2], std::fmin(box.h[2], c.z))};
  const V3 diff = c - q;
  const double d2 = norm2(diff);
  if (d2 > 0) {
    // Centre outside the box: the closest box point decides.
    if (d2 > r * r) return false;
    if (hit) {
      const double dist = std::sqrt(d2);
      hit->normal = box.to_world(diff * (1.0 / dist));
      hit->depth = r - dist;
      const V3 surface = box.centre + box.to_world(q);
      hit->point = 0.5 * (surface + (sphere.centre - hit->normal * r));
    }
    return true;
  }
  if (hit) {
    // Centre inside (or on) the box: push out through the nearest face.
    int k = 0;
    double best = INFINITY;
    for (int i = 0; i < 3; ++i) {
      const double room = box.h[i] - std::fabs(c[i]);
      if (room < best) {
        best = room;
        k = i;
      }
    }
    const double s = c[k] >= 0 ? 1.0 : -1.0;
    V3 n_local{};
    V3 face = c;
    if (k == 0) {
      n_local.x = s;
      face.x = s * box.h[0];
    } else if (k == 1) {
      n_local.y = s;
      face.y = s * box.h[1];
    } else {
      n_local.z = s;
      face.z = s * box.h[2];
    }
    hit->normal = box.to_world(n_local);
    hit->depth = r + best;
    hit->point = 0.5 * ((box.centre + box.to_world(face)) + (sphere.centre - hit->normal * r));
  }
  return true;
}

}  // namespace hbp::narrow
