// SPDX-License-Identifier: MIT
#pragma once
// Ray traversal of the two-level hierarchy: the k-d tree front to back, and in
// each cell the cell's BVH, nearer child first; the walk stops once the
// closest hit lies before the current cell's exit. Shape tests are exact
// (ray_shape.hpp); `geometry` is indexed by object id.
//
//   hbp::RayHit hit = hbp::closest_hit(hierarchy, geometry, ray);
//   bool shadowed = hbp::any_hit(hierarchy, geometry, shadow_ray);
#include <span>

#include "hbp/raytrace/ray.hpp"
#include "hbp/raytrace/ray_shape.hpp"
#include "hbp/two_level_hierarchy.hpp"

namespace hbp {

RayHit closest_hit(const TwoLevelHierarchy& hierarchy, std::span<const ShapeGeometry> geometry, const Ray& ray);
// True if anything is hit with tmin <= t <= tmax (stops at the first hit).
bool any_hit(const TwoLevelHierarchy& hierarchy, std::span<const ShapeGeometry> geometry, const Ray& ray);

// The same over one BVH (e.g. a full-scene BVH; leaves' `object` index
// `geometry`).
RayHit closest_hit(std::span<const BvhNode> bvh, std::span<const ShapeGeometry> geometry, const Ray& ray);
bool any_hit(std::span<const BvhNode> bvh, std::span<const ShapeGeometry> geometry, const Ray& ray);

// The oracle: every object tested.
RayHit brute_force_closest_hit(std::span<const ShapeGeometry> geometry, const Ray& ray);
bool brute_force_any_hit(std::span<const ShapeGeometry> geometry, const Ray& ray);

}  // namespace hbp
