#pragma once
// GJK (Gilbert-Johnson-Keerthi) on the Minkowski difference D = A - B of two
// convex shapes: decides whether the origin lies in D, and if not returns the
// distance and closest points. Fixed-size simplex, no allocation.
#include "hbp/narrow/convex.hpp"

namespace hbp::narrow {

// A point of D with the support points of A and B that produced it.
struct SupportVertex {
  V3 w, a, b;  // w = a - b
};

inline SupportVertex support_difference(const Convex& A, const Convex& B, const V3& d) {
  SupportVertex s;
  s.a = A.support(d);
  s.b = B.support(-d);
  s.w = s.a - s.b;
  return s;
}

struct Simplex {
  SupportVertex v[4];
  double lambda[4] = {0, 0, 0, 0};  // barycentric weights of the closest point
  int n = 0;
};

struct GjkResult {
  bool intersecting = false;
  // Separated: distance (within the relative tolerance) and witness points.
  // Intersecting: 0. Boolean-only queries that stop early on a separating
  // plane report a lower bound of the distance instead.
  double distance = 0;
  V3 closest_a, closest_b;
  Simplex simplex;  // final simplex; encloses (or touches) the origin if intersecting
  V3 v;             // last search vector (separated: -v is a separating direction)
  int iterations = 0;
};

struct GjkOptions {
  bool boolean_only = false;     // stop at the first separating plane
  double rel_tolerance = 1e-10;  // on the distance
  int max_iterations = 128;
  // First search direction (the cached one of the last frame: from a
  // towards b); zero: the centre line.
  V3 initial_direction;
};

GjkResult gjk(const Convex& a, const Convex& b, const GjkOptions& options = {});

}  // namespace hbp::narrow
