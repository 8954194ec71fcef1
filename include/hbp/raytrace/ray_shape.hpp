// SPDX-License-Identifier: MIT
#pragma once
// Exact ray intersection with the four oriented shapes (ellipsoid "sphere",
// cuboid, elliptic cylinder, elliptic cone; local frames as in shape.hpp). The
// ray is taken into the shape's frame and the closed form (quadratic or slab)
// is solved in double.
//
//   std::vector<hbp::ShapeGeometry> g = hbp::prepare_shapes(scenario.shapes());
//   double t; std::uint8_t part;
//   if (hbp::intersect_ray(g[i], ray, ray.tmin, ray.tmax, t, part)) ...
#include <cstdint>
#include <span>
#include <vector>

#include "hbp/raytrace/ray.hpp"
#include "hbp/shape.hpp"

namespace hbp {

// A shape ready for ray tests: rotation (local -> world, row-major), centre,
// half extents, kind.
struct ShapeGeometry {
  double rot[3][3];
  double centre[3];
  double half[3];
  ShapeKind kind;
};

ShapeGeometry prepare_shape(const Shape& shape);
void prepare_shapes(std::span<const Shape> shapes, std::vector<ShapeGeometry>& out);  // parallel

// Nearest t in [tmin, tmax] where the ray meets the shape's surface (a ray
// starting inside meets it on the way out). `part` tells which surface:
// 0 curved side / ellipsoid, 1 top cap (+z), 2 bottom cap or cone base (-z);
// cuboid: 2 * axis + (1 if the + face).
bool intersect_ray(const ShapeGeometry& g, const Ray& ray, double tmin, double tmax, double& t, std::uint8_t& part);

// Unit outward surface normal (world frame) at the point `p` of surface `part`.
void surface_normal(const ShapeGeometry& g, const double p[3], std::uint8_t part, double n[3]);

}  // namespace hbp
