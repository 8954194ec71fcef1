// SPDX-License-Identifier: MIT
#include "hbp/shape.hpp"

#include <algorithm>
#include <cmath>
#include <limits>

namespace hbp {

const char* shape_kind_name(ShapeKind kind) {
  switch (kind) {
    case ShapeKind::Sphere: return "sphere";
    case ShapeKind::Cuboid: return "cuboid";
    case ShapeKind::Cylinder: return "cylinder";
    case ShapeKind::Cone: return "cone";
  }
  return "unknown";
}

void rotation_matrix(const Quat& q, double r[3][3]) {
  const double w = q.w, x = q.x, y = q.y, z = q.z;
  r[0][0] = 1 - 2 * (y * y + z * z);
  r[0][1] = 2 * (x * y - w * z);
  r[0][2] = 2 * (x * z + w * y);
  r[1][0] = 2 * (x * y + w * z);
  r[1][1] = 1 - 2 * (x * x + z * z);
  r[1][2] = 2 * (y * z - w * x);
  r[2][0] = 2 * (x * z - w * y);
  r[2][1] = 2 * (y * z + w * x);
  r[2][2] = 1 - 2 * (x * x + y * y);
}

Quat normalized(const Quat& q) {
  const double len = std::sqrt(q.w * q.w + q.x * q.x + q.y * q.y + q.z * q.z);
  if (len == 0) return Quat{};
  return {q.w / len, q.x / len, q.y / len, q.z / len};
}

Quat multiply(const Quat& a, const Quat& b) {
  return {a.w * b.w - a.x * b.x - a.y * b.y - a.z * b.z,
          a.w * b.x + a.x * b.w + a.y * b.z - a.z * b.y,
          a.w * b.y - a.x * b.z + a.y * b.w + a.z * b.x,
          a.w * b.z + a.x * b.y - a.y * b.x + a.z * b.w};
}

Quat integrate_rotation(const Quat& q, const Vec3& w, double dt) {
  // Exact rotation by the angle |w| dt about w (constant world-frame angular
  // velocity), then renormalised so drift never accumulates.
  const double speed = std::sqrt(w.x * w.x + w.y * w.y + w.z * w.z);
  if (speed == 0) return q;
  const double half = 0.5 * speed * dt;
  const double s = std::sin(half) / speed;
  const Quat dq{std::cos(half), w.x * s, w.y * s, w.z * s};
  return normalized(multiply(dq, q));
}

namespace {

// Support value h(u) = max over the shape (in its local frame) of dot(p, u),
// and the maximising point.
double local_support(const Shape& s, const double u[3], double p[3]) {
  const double ax = 0.5 * s.size.x, ay = 0.5 * s.size.y, az = 0.5 * s.size.z;
  switch (s.kind) {
    case ShapeKind::Sphere: {
      const double sx = ax * u[0], sy = ay * u[1], sz = az * u[2];
      const double len = std::sqrt(sx * sx + sy * sy + sz * sz);
      if (len == 0) {
        p[0] = p[1] = p[2] = 0;
        return 0;
      }
      p[0] = ax * sx / len;
      p[1] = ay * sy / len;
      p[2] = az * sz / len;
      return len;
    }
    case ShapeKind::Cuboid: {
      p[0] = u[0] >= 0 ? ax : -ax;
      p[1] = u[1] >= 0 ? ay : -ay;
      p[2] = u[2] >= 0 ? az : -az;
      return ax * std::fabs(u[0]) + ay * std::fabs(u[1]) + az * std::fabs(u[2]);
    }
    case ShapeKind::Cylinder:
    case ShapeKind::Cone: {
      // Rim of the elliptic disk: support of the ellipse in (u.x, u.y).
      const double sx = ax * u[0], sy = ay * u[1];
      const double len = std::sqrt(sx * sx + sy * sy);
      const double rx = len == 0 ? ax : ax * sx / len;
      const double ry = len == 0 ? 0 : ay * sy / len;
      if (s.kind == ShapeKind::Cylinder) {
        p[0] = rx;
        p[1] = ry;
        p[2] = u[2] >= 0 ? az : -az;
        return len + az * std::fabs(u[2]);
      }
      const double apex = az * u[2];
      const double base = -az * u[2] + len;
      if (apex >= base) {
        p[0] = 0;
        p[1] = 0;
        p[2] = az;
        return apex;
      }
      p[0] = rx;
      p[1] = ry;
      p[2] = -az;
      return base;
    }
  }
  p[0] = p[1] = p[2] = 0;
  return 0;
}

float round_down(double v) {
  float f = static_cast<float>(v);
  if (static_cast<double>(f) > v) f = std::nextafter(f, -std::numeric_limits<float>::infinity());
  return f;
}

float round_up(double v) {
  float f = static_cast<float>(v);
  if (static_cast<double>(f) < v) f = std::nextafter(f, std::numeric_limits<float>::infinity());
  return f;
}

}  // namespace

Aabb tight_aabb(const Shape& shape) {
  double r[3][3];
  rotation_matrix(shape.orientation, r);
  Aabb box{};
  double p[3];
  for (int i = 0; i < 3; ++i) {
    // Local direction of world axis i is row i of R.
    const double up[3] = {r[i][0], r[i][1], r[i][2]};
    const double un[3] = {-r[i][0], -r[i][1], -r[i][2]};
    const double hi = local_support(shape, up, p);
    const double lo = local_support(shape, un, p);
    box.max[i] = round_up(shape.position[i] + hi);
    box.min[i] = round_down(shape.position[i] - lo);
  }
  return box;
}

Vec3 support_point(const Shape& shape, const Vec3& d) {
  double r[3][3];
  rotation_matrix(shape.orientation, r);
  double u[3];
  for (int j = 0; j < 3; ++j) u[j] = r[0][j] * d.x + r[1][j] * d.y + r[2][j] * d.z;
  double p[3];
  local_support(shape, u, p);
  Vec3 w;
  w.x = shape.position.x + r[0][0] * p[0] + r[0][1] * p[1] + r[0][2] * p[2];
  w.y = shape.position.y + r[1][0] * p[0] + r[1][1] * p[1] + r[1][2] * p[2];
  w.z = shape.position.z + r[2][0] * p[0] + r[2][1] * p[1] + r[2][2] * p[2];
  return w;
}

}  // namespace hbp
