// SPDX-License-Identifier: MIT
#include "hbp/raytrace/camera.hpp"

#include <algorithm>
#include <cmath>

namespace hbp {

namespace {

void normalize(double v[3]) {
  const double len = std::sqrt(v[0] * v[0] + v[1] * v[1] + v[2] * v[2]);
  for (int k = 0; k < 3; ++k) v[k] /= len;
}

void cross(const double a[3], const double b[3], double out[3]) {
  out[0] = a[1] * b[2] - a[2] * b[1];
  out[1] = a[2] * b[0] - a[0] * b[2];
  out[2] = a[0] * b[1] - a[1] * b[0];
}

// Viewing direction from the cube's centre towards the eye: in front
// (-y), to the right (+x) and above (+z).
constexpr double kViewFrom[3] = {0.62, -1.0, 0.58};
constexpr double kLightFrom[3] = {-0.55, -0.8, 1.45};

}  // namespace

Ray Camera::primary(double x, double y, std::uint32_t width, std::uint32_t height) const {
  const double sx = (2 * (x + 0.5) / width - 1) * aspect * tan_half_fov;
  const double sy = (1 - 2 * (y + 0.5) / height) * tan_half_fov;
  Ray r;
  for (int k = 0; k < 3; ++k) {
    r.origin[k] = eye[k];
    r.dir[k] = forward[k] + sx * right[k] + sy * up[k];
  }
  r.tmin = 0;
  r.tmax = 1e300;
  return r;
}

bool Camera::project(const double p[3], std::uint32_t width, std::uint32_t height, double& x, double& y,
                     double& depth) const {
  double v[3] = {p[0] - eye[0], p[1] - eye[1], p[2] - eye[2]};
  depth = v[0] * forward[0] + v[1] * forward[1] + v[2] * forward[2];
  if (!(depth > 0)) return false;
  const double sx = (v[0] * right[0] + v[1] * right[1] + v[2] * right[2]) / depth;
  const double sy = (v[0] * up[0] + v[1] * up[1] + v[2] * up[2]) / depth;
  x = (sx / (aspect * tan_half_fov) + 1) * 0.5 * width - 0.5;
  y = (1 - sy / tan_half_fov) * 0.5 * height - 0.5;
  return true;
}

Camera frame_cube(const Aabb& cube, double aspect, double vertical_fov_degrees) {
  Camera c;
  c.aspect = aspect;
  c.tan_half_fov = std::tan(0.5 * vertical_fov_degrees * 3.14159265358979323846 / 180);
  double centre[3], radius2 = 0;
  for (int k = 0; k < 3; ++k) {
    centre[k] = 0.5 * (double(cube.min[k]) + cube.max[k]);
    const double h = 0.5 * (double(cube.max[k]) - cube.min[k]);
    radius2 += h * h;
  }
  // The cube's bounding sphere fits the narrower field of view.
  const double half_fov = std::atan(c.tan_half_fov * std::min(1.0, aspect));
  const double distance = 1.02 * std::sqrt(radius2) / std::sin(half_fov);
  double from[3] = {kViewFrom[0], kViewFrom[1], kViewFrom[2]};
  normalize(from);
  for (int k = 0; k < 3; ++k) {
    c.eye[k] = centre[k] + distance * from[k];
    c.forward[k] = -from[k];
  }
  const double world_up[3] = {0, 0, 1};
  cross(c.forward, world_up, c.right);
  normalize(c.right);
  cross(c.right, c.forward, c.up);
  return c;
}

PointLight light_for_cube(const Aabb& cube) {
  PointLight l;
  for (int k = 0; k < 3; ++k) {
    const double centre = 0.5 * (double(cube.min[k]) + cube.max[k]);
    const double side = double(cube.max[k]) - cube.min[k];
    l.position[k] = centre + 1.6 * side * kLightFrom[k];
  }
  return l;
}

}  // namespace hbp
