// SPDX-License-Identifier: MIT
#include "hbp/raytrace/ray_shape.hpp"

#include <tbb/parallel_for.h>

#include <algorithm>
#include <cmath>
#include <limits>
#include <utility>

namespace hbp {

ShapeGeometry prepare_shape(const Shape& shape) {
  ShapeGeometry g{};
  rotation_matrix(shape.orientation, g.rot);
  g.centre[0] = shape.position.x;
  g.centre[1] = shape.position.y;
  g.centre[2] = shape.position.z;
  g.half[0] = 0.5 * shape.size.x;
  g.half[1] = 0.5 * shape.size.y;
  g.half[2] = 0.5 * shape.size.z;
  g.kind = shape.kind;
  return g;
}

void prepare_shapes(std::span<const Shape> shapes, std::vector<ShapeGeometry>& out) {
  out.resize(shapes.size());
  tbb::parallel_for(tbb::blocked_range<std::size_t>(0, shapes.size(), 4096), [&](const auto& r) {
    for (std::size_t i = r.begin(); i != r.end(); ++i) out[i] = prepare_shape(shapes[i]);
  });
}

namespace {

// Rims, edges and the apex are part of the closed surfaces: a ray through
// one must not slip between the two surfaces meeting there by rounding, so
// the bounds of each surface patch are widened by a relative 1e-12 (far
// below float32 AABB precision, which the traversal's culling allows for).
constexpr double kClosed = 1 + 1e-12;

// Real roots of a t^2 + 2 b t + c = 0, ascending (numerically stable form).
int solve_quadratic(double a, double b, double c, double r[2]) {
  if (a == 0) {
    if (b == 0) return 0;
    r[0] = -c / (2 * b);
    return 1;
  }
  double disc = b * b - a * c;
  if (disc < 0) {
    // A tangent ray (double root, e.g. through the cone's apex) can round to a
    // slightly negative discriminant.
    if (disc < -1e-14 * b * b) return 0;
    disc = 0;
  }
  const double q = -(b + std::copysign(std::sqrt(disc), b));
  if (q == 0) {  // b == 0 and disc == 0, so c == 0: a double root at 0
    r[0] = 0;
    return 1;
  }
  r[0] = q / a;
  r[1] = c / q;
  if (r[0] > r[1]) std::swap(r[0], r[1]);
  return 2;
}

struct Best {
  double t;
  std::uint8_t part = 0;
  bool found = false;
  void offer(double cand, std::uint8_t p, double tmin) {
    if (cand >= tmin && cand <= t) {
      t = cand;
      part = p;
      found = true;
    }
  }
};

bool ellipsoid(const double o[3], const double d[3], const double h[3], double tmin, Best& best) {
  if (!(h[0] > 0 && h[1] > 0 && h[2] > 0)) return false;
  double O[3], D[3];
  for (int k = 0; k < 3; ++k) {
    O[k] = o[k] / h[k];
    D[k] = d[k] / h[k];
  }
  double r[2];
  const int n = solve_quadratic(D[0] * D[0] + D[1] * D[1] + D[2] * D[2], O[0] * D[0] + O[1] * D[1] + O[2] * D[2],
                                O[0] * O[0] + O[1] * O[1] + O[2] * O[2] - 1, r);
  for (int i = 0; i < n; ++i) best.offer(r[i], 0, tmin);
  return best.found;
}

bool cuboid(const double o[3], const double d[3], const double h[3], double tmin, Best& best) {
  double t_near = -std::numeric_limits<double>::infinity(), t_far = std::numeric_limits<double>::infinity();
  std::uint8_t near_part = 0, far_part = 0;
  for (int k = 0; k < 3; ++k) {
    if (d[k] == 0) {
      if (o[k] < -h[k] || o[k] > h[k]) return false;
      continue;
    }
    const double ta = (-h[k] - o[k]) / d[k], tb = (h[k] - o[k]) / d[k];
    // Entering through the face the ray points into: the - face when d > 0.
    const double lo = std::min(ta, tb), hi = std::max(ta, tb);
    const auto enter = static_cast<std::uint8_t>(2 * k + (d[k] > 0 ? 0 : 1));
    const auto leave = static_cast<std::uint8_t>(2 * k + (d[k] > 0 ? 1 : 0));
    if (lo > t_near) {
      t_near = lo;
      near_part = enter;
    }
    if (hi < t_far) {
      t_far = hi;
      far_part = leave;
    }
  }
  if (t_near > t_far) return false;
  best.offer(t_near, near_part, tmin);
  if (!best.found) best.offer(t_far, far_part, tmin);
  return best.found;
}

bool cylinder(const double o[3], const double d[3], const double h[3], double tmin, Best& best) {
  if (!(h[0] > 0 && h[1] > 0)) return false;
  const double ox = o[0] / h[0], oy = o[1] / h[1], dx = d[0] / h[0], dy = d[1] / h[1];
  double r[2];
  const int n = solve_quadratic(dx * dx + dy * dy, ox * dx + oy * dy, ox * ox + oy * oy - 1, r);
  for (int i = 0; i < n; ++i) {
    const double z = o[2] + r[i] * d[2];
    if (std::fabs(z) <= h[2] * kClosed) best.offer(r[i], 0, tmin);
  }
  if (d[2] != 0) {
    for (int s = 0; s < 2; ++s) {
      const double zc = s == 0 ? h[2] : -h[2];
      const double t = (zc - o[2]) / d[2];
      const double x = ox + t * dx, y = oy + t * dy;
      if (x * x + y * y <= kClosed) best.offer(t, static_cast<std::uint8_t>(1 + s), tmin);
    }
  }
  return best.found;
}

bool cone(const double o[3], const double d[3], const double h[3], double tmin, Best& best) {
  if (!(h[0] > 0 && h[1] > 0 && h[2] > 0)) return false;
  const double ox = o[0] / h[0], oy = o[1] / h[1], dx = d[0] / h[0], dy = d[1] / h[1];
  // Normalised radius w = (h_z - z) / (2 h_z): 0 at the apex, 1 at the base.
  const double w0 = (h[2] - o[2]) / (2 * h[2]), wd = -d[2] / (2 * h[2]);
  double r[2];
  const int n = solve_quadratic(dx * dx + dy * dy - wd * wd, ox * dx + oy * dy - w0 * wd, ox * ox + oy * oy - w0 * w0, r);
  for (int i = 0; i < n; ++i) {
    const double w = w0 + r[i] * wd;
    if (w >= 1 - kClosed && w <= kClosed) best.offer(r[i], 0, tmin);
  }
  if (d[2] != 0) {
    const double t = (-h[2] - o[2]) / d[2];
    const double x = ox + t * dx, y = oy + t * dy;
    if (x * x + y * y <= kClosed) best.offer(t, 2, tmin);
  }
  return best.found;
}

}  // namespace

bool intersect_ray(const ShapeGeometry& g, const Ray& ray, double tmin, double tmax, double& t, std::uint8_t& part) {
  // Into the local frame: R^T (x - c).
  double o[3], d[3];
  const double rel[3] = {ray.origin[0] - g.centre[0], ray.origin[1] - g.centre[1], ray.origin[2] - g.centre[2]};
  for (int j = 0; j < 3; ++j) {
    o[j] = g.rot[0][j] * rel[0] + g.rot[1][j] * rel[1] + g.rot[2][j] * rel[2];
    d[j] = g.rot[0][j] * ray.dir[0] + g.rot[1][j] * ray.dir[1] + g.rot[2][j] * ray.dir[2];
  }
  Best best{tmax};
  bool hit = false;
  switch (g.kind) {
    case ShapeKind::Sphere: hit = ellipsoid(o, d, g.half, tmin, best); break;
    case ShapeKind::Cuboid: hit = cuboid(o, d, g.half, tmin, best); break;
    case ShapeKind::Cylinder: hit = cylinder(o, d, g.half, tmin, best); break;
    case ShapeKind::Cone: hit = cone(o, d, g.half, tmin, best); break;
  }
  if (!hit) return false;
  t = best.t;
  part = best.part;
  return true;
}

void surface_normal(const ShapeGeometry& g, const double p[3], std::uint8_t part, double n[3]) {
  double l[3];
  const double rel[3] = {p[0] - g.centre[0], p[1] - g.centre[1], p[2] - g.centre[2]};
  for (int j = 0; j < 3; ++j) l[j] = g.rot[0][j] * rel[0] + g.rot[1][j] * rel[1] + g.rot[2][j] * rel[2];
  const double* h = g.half;
  auto sq = [](double v) { return v > 0 ? v * v : 1.0; };
  double m[3] = {0, 0, 0};
  switch (g.kind) {
    case ShapeKind::Sphere:
      m[0] = l[0] / sq(h[0]);
      m[1] = l[1] / sq(h[1]);
      m[2] = l[2] / sq(h[2]);
      break;
    case ShapeKind::Cuboid: m[part / 2] = (part & 1) ? 1 : -1; break;
    case ShapeKind::Cylinder:
    case ShapeKind::Cone:
      if (part == 1) {
        m[2] = 1;
      } else if (part == 2) {
        m[2] = -1;
      } else {
        m[0] = l[0] / sq(h[0]);
        m[1] = l[1] / sq(h[1]);
        if (g.kind == ShapeKind::Cone && h[2] > 0) {
          const double w = (h[2] - l[2]) / (2 * h[2]);
          if (w < 1e-9) {  // the apex: no tangent plane, use the axis
            m[0] = m[1] = 0;
            m[2] = 1;
          } else {
            m[2] = w / (2 * h[2]);
          }
        }
      }
      break;
  }
  double len = 0;
  for (int i = 0; i < 3; ++i) {
    n[i] = g.rot[i][0] * m[0] + g.rot[i][1] * m[1] + g.rot[i][2] * m[2];
    len += n[i] * n[i];
  }
  len = std::sqrt(len);
  if (len > 0) {
    for (int i = 0; i < 3; ++i) n[i] /= len;
  } else {  // the cone's apex: its axis
    for (int i = 0; i < 3; ++i) n[i] = g.rot[i][2];
  }
}

}  // namespace hbp
