// SPDX-License-Identifier: MIT
#pragma once
// A pinhole camera and a point light placed to frame the scenario's cube the
// way the paper's Fig. 3 does: the whole cube in view, seen from above one of
// its front corners, lit from above the viewer's left.
#include <cstdint>

#include "hbp/aabb.hpp"
#include "hbp/raytrace/ray.hpp"

namespace hbp {

struct Camera {
  double eye[3];
  double forward[3], right[3], up[3];  // orthonormal
  double tan_half_fov = 0.35;          // vertical
  double aspect = 1;                   // width / height

  // Ray through the pixel position (x, y) of a width x height image (y down,
  // pixel centres at +0.5). Its t is the depth along `forward`.
  Ray primary(double x, double y, std::uint32_t width, std::uint32_t height) const;
  // Pixel position and depth of a world point; false if behind the camera.
  bool project(const double p[3], std::uint32_t width, std::uint32_t height, double& x, double& y,
               double& depth) const;
};

struct PointLight {
  double position[3];
};

Camera frame_cube(const Aabb& cube, double aspect, double vertical_fov_degrees = 38);
PointLight light_for_cube(const Aabb& cube);

}  // namespace hbp
