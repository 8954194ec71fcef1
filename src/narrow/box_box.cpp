// SPDX-License-Identifier: MIT
#include <cmath>

#include "hbp/narrow/closed_forms.hpp"

namespace hbp::narrow {
namespace {

double clampd(double v, double lo, double hi) { return std::fmax(lo, std::fmin(hi, v)); }

// Point of box `face_box` on its face with outward normal along +-axis k
// (sign s), nearest to p laterally.
V3 face_point(const Convex& box, int k, double s, const V3& p) {
  V3 q = box.to_local(p - box.centre);
  double l[3] = {clampd(q.x, -box.h[0], box.h[0]), clampd(q.y, -box.h[1], box.h[1]),
                 clampd(q.z, -box.h[2], box.h[2])};
  l[k] = s * box.h[k];
  return box.centre + box.to_world({l[0], l[1], l[2]});
}

// Midpoint of the edge of `box` parallel to local axis k that is extreme in
// direction d.
V3 support_edge_centre(const Convex& box, int k, const V3& d) {
  V3 p = box.centre;
  for (int m = 0; m < 3; ++m) {
    if (m == k) continue;
    const V3 ax = box.axis(m);
    p = p + ax * (dot(ax, d) >= 0 ? box.h[m] : -box.h[m]);
  }
  return p;
}

}  // namespace

bool box_box(const Convex& A, const Convex& B, Hit* hit) {
  const V3 a[3] = {A.axis(0), A.axis(1), A.axis(2)};
  const V3 b[3] = {B.axis(0), B.axis(1), B.axis(2)};
  const V3 T = B.centre - A.centre;
  double ar[3][3];
  for (int i = 0; i < 3; ++i)
    for (int j = 0; j < 3; ++j) ar[i][j] = std::fabs(dot(a[i], b[j]));

  double best = INFINITY;
  V3 axis{0, 0, 1};
  int kind = 0, bi = 0, bj = 0;  // kind 0: face of A, 1: face of B, 2: edge x edge
  auto consider = [&](double overlap, const V3& l, double t, int k, int i, int j) {
    if (overlap < best) {
      best = overlap;
      axis = t >= 0 ? l : -l;
      kind = k;
      bi = i;
      bj = j;
    }
  };
  for (int i = 0; i < 3; ++i) {
    const double rb = B.h[0] * ar[i][0] + B.h[1] * ar[i][1] + B.h[2] * ar[i][2];
    const double t = dot(T, a[i]);
    const double overlap = A.h[i] + rb - std::fabs(t);
    if (overlap < 0) return false;
    consider(overlap, a[i], t, 0, i, 0);
  }
  for (int j = 0; j < 3; ++j) {
    const double ra = A.h[0] * ar[0][j] + A.h[1] * ar[1][j] + A.h[2] * ar[2][j];
    const double t = dot(T, b[j]);
    const double overlap = ra + B.h[j] - std::fabs(t);
    if (overlap < 0) return false;
    consider(overlap, b[j], t, 1, 0, j);
  }
  for (int i = 0; i < 3; ++i) {
    for (int j = 0; j < 3; ++j) {
      V3 l = cross(a[i], b[j]);
      const double len = norm(l);
      if (len < 1e-9) continue;  // parallel edges: the face axes cover it
      l = l * (1.0 / len);
      const double ra = A.h[0] * std::fabs(dot(a[0], l)) + A.h[1] * std::fabs(dot(a[1], l)) +
                        A.h[2] * std::fabs(dot(a[2], l));
      const double rb = B.h[0] * std::fabs(dot(b[0], l)) + B.h[1] * std::fabs(dot(b[1], l)) +
                        B.h[2] * std::fabs(dot(b[2], l));
      const double t = dot(T, l);
      const double overlap = ra + rb - std::fabs(t);
      if (overlap < 0) return false;
      consider(overlap, l, t, 2, i, j);
    }
  }
  if (!hit) return true;
  hit->normal = axis;
  hit->depth = best;
  if (kind == 0) {
    // Face of A: the deepest vertex of B, projected onto that face.
    const V3 deep_b = B.support(-axis);
    const double s = dot(axis, a[bi]) >= 0 ? 1.0 : -1.0;
    hit->point = face_point(A, bi, s, deep_b) - axis * (0.5 * best);
  } else if (kind == 1) {
    const V3 deep_a = A.support(axis);
    const double s = dot(-axis, b[bj]) >= 0 ? 1.0 : -1.0;
    hit->point = face_point(B, bj, s, deep_a) + axis * (0.5 * best);
  } else {
    // Edge x edge: closest points of the two extreme edges.
    const V3 pa = support_edge_centre(A, bi, axis), da = a[bi];
    const V3 pb = support_edge_centre(B, bj, -axis), db = b[bj];
    const V3 r = pa - pb;
    const double bb = dot(da, db), c = dot(da, r), f = dot(db, r);
    const double den = 1 - bb * bb;
    double s = den > 0 ? (bb * f - c) / den : 0;
    s = clampd(s, -A.h[bi], A.h[bi]);
    double t = clampd(bb * s + f, -B.h[bj], B.h[bj]);
    s = clampd(bb * t - c, -A.h[bi], A.h[bi]);
    hit->point = 0.5 * ((pa + da * s) + (pb + db * t));
  }
  return true;
}

}  // namespace hbp::narrow
