// SPDX-License-Identifier: MIT
#pragma once
// EPA (expanding polytope algorithm): penetration depth, normal and witness
// points of two intersecting convex shapes, grown from GJK's final simplex.
// The polytope lives in fixed-size arrays on the stack: no allocation.
#include "hbp/narrow/gjk.hpp"

namespace hbp::narrow {

struct EpaResult {
  // False only when no polytope could be built; the fields then hold the
  // support function's bound along the centre line refined by descent, and
  // `separated` says whether that bound proves the shapes apart.
  bool ok = false;
  bool separated = false;
  bool converged = false;  // gap below tolerance (else capacity or degeneracy)
  double depth = 0;        // >= 0 (if not converged: the best upper bound)
  double lower_bound = 0;  // the closest polytope face: depth >= lower_bound
  V3 normal;               // unit, from A towards B
  V3 point_a, point_b;     // deepest points of A and B along the normal
  int iterations = 0;
};

struct EpaOptions {
  double rel_tolerance = 1e-6;  // on the depth
  double abs_tolerance = 1e-10; // times the pair scale
};

inline constexpr int kEpaMaxVertices = 192;

EpaResult epa(const Convex& a, const Convex& b, const Simplex& simplex, const EpaOptions& options = {});

}  // namespace hbp::narrow
