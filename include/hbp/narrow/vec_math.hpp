// SPDX-License-Identifier: MIT
#pragma once
// Small double-precision 3-vector used inside the narrow phase. A type of its
// own (not hbp::Vec3) so its operators never clash with other modules'.
#include <cmath>

#include "hbp/shape.hpp"

namespace hbp::narrow {

struct V3 {
  double x = 0, y = 0, z = 0;
  double operator[](int i) const { return i == 0 ? x : (i == 1 ? y : z); }
};

inline V3 to_v3(const Vec3& v) { return {v.x, v.y, v.z}; }
inline Vec3 to_vec3(const V3& v) { return {v.x, v.y, v.z}; }

inline V3 operator+(const V3& a, const V3& b) { return {a.x + b.x, a.y + b.y, a.z + b.z}; }
inline V3 operator-(const V3& a, const V3& b) { return {a.x - b.x, a.y - b.y, a.z - b.z}; }
inline V3 operator-(const V3& a) { return {-a.x, -a.y, -a.z}; }
inline V3 operator*(const V3& a, double s) { return {a.x * s, a.y * s, a.z * s}; }
inline V3 operator*(double s, const V3& a) { return {a.x * s, a.y * s, a.z * s}; }
inline double dot(const V3& a, const V3& b) { return a.x * b.x + a.y * b.y + a.z * b.z; }
inline V3 cross(const V3& a, const V3& b) {
  return {a.y * b.z - a.z * b.y, a.z * b.x - a.x * b.z, a.x * b.y - a.y * b.x};
}
inline double norm2(const V3& a) { return dot(a, a); }
inline double norm(const V3& a) { return std::sqrt(dot(a, a)); }
inline double det3(const V3& a, const V3& b, const V3& c) { return dot(a, cross(b, c)); }

}  // namespace hbp::narrow
