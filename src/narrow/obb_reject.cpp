// SPDX-License-Identifier: MIT
#include "hbp/narrow/obb_reject.hpp"

#include <cmath>

namespace hbp::narrow {

bool obb_disjoint(const Convex& A, const Convex& B, V3* axis) {
  const V3 a[3] = {A.axis(0), A.axis(1), A.axis(2)};
  const V3 b[3] = {B.axis(0), B.axis(1), B.axis(2)};
  const V3 T = B.centre - A.centre;
  double ar[3][3];
  for (int i = 0; i < 3; ++i)
    for (int j = 0; j < 3; ++j) ar[i][j] = std::fabs(dot(a[i], b[j]));
  auto found = [&](const V3& l, double t) {
    if (axis) {
      const V3 u = l * (1.0 / norm(l));
      *axis = t >= 0 ? u : -u;
    }
    return true;
  };
  for (int i = 0; i < 3; ++i) {
    const double t = dot(T, a[i]);
    if (std::fabs(t) > A.h[i] + B.h[0] * ar[i][0] + B.h[1] * ar[i][1] + B.h[2] * ar[i][2]) return found(a[i], t);
  }
  for (int j = 0; j < 3; ++j) {
    const double t = dot(T, b[j]);
    if (std::fabs(t) > B.h[j] + A.h[0] * ar[0][j] + A.h[1] * ar[1][j] + A.h[2] * ar[2][j]) return found(b[j], t);
  }
  // Edge-edge axes a_i x b_j; nearly parallel edges give no axis the face
  // axes do not already cover.
  for (int i = 0; i < 3; ++i) {
    for (int j = 0; j < 3; ++j) {
      const V3 l = cross(a[i], b[j]);
      const double len2 = norm2(l);
      if (len2 < 1e-12) continue;
      const double t = dot(T, l);
      double ra = 0, rb = 0;
      for (int k = 0; k < 3; ++k) {
        ra += A.h[k] * std::fabs(dot(a[k], l));
        rb += B.h[k] * std::fabs(dot(b[k], l));
      }
      if (std::fabs(t) > ra + rb) return found(l, t);
    }
  }
  return false;
}

}  // namespace hbp::narrow
