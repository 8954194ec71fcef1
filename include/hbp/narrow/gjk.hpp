// SPDX-License-Identifier: MIT
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
  // The support directions that produced v (v[i] = support_difference(a,
  // b, dir[i])): next frame, the same directions give a colliding pair its
  // tetrahedron again without GJK's iterations.
  V3 dir[4];
  int n = 0;

  Simplex() = default;
  // A tetrahedron of four support points and their directions, built in
  // place: the default constructor's zeroing of v and dir (424 bytes, a
  // `rep stos`) is skipped, they are initialised from these.
  Simplex(const SupportVertex& v0, const SupportVertex& v1, const SupportVertex& v2, const SupportVertex& v3,
          const V3& d0, const V3& d1, const V3& d2, const V3& d3)
      : v{v0, v1, v2, v3}, dir{d0, d1, d2, d3}, n(4) {}
};

// The origin strictly inside the tetrahedron s.v[0..3] (s.n == 4): the test
// that ends GJK on an intersecting pair, sliver rule included (a tetrahedron
// too flat for its face-side tests to mean anything never encloses).
bool tetrahedron_encloses_origin(const Simplex& s);

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
  // Distance mode: when > 0, the tolerance is relative to (shell - distance)
  // instead: the distance of two cores whose shapes are those cores grown
  // by balls with radii summing to `shell`, where the shapes' depth is
  // shell - distance (narrow::intersect's rounded pairs).
  double shell = 0;
  int max_iterations = 128;
  // First search direction (the cached one of the last frame: from a
  // towards b); zero: the centre line.
  V3 initial_direction;
  // A tetrahedron of support points to start from (e.g. the cone around
  // last frame's contact normal; null or n != 4: none). GJK goes on from its
  // closest feature to the origin.
  const Simplex* initial_simplex = nullptr;
};

GjkResult gjk(const Convex& a, const Convex& b, const GjkOptions& options = {});

}  // namespace hbp::narrow
