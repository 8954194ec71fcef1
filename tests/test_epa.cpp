// SPDX-License-Identifier: MIT
// EPA's polytope (src/narrow/epa_polytope.hpp): the bracket it reports is
// certified. On random colliding pairs of every kind, the lower bound (the
// closest face of the inscribed polytope) never exceeds a much tighter
// reference's upper bound, the reported depth (the upper end) is never below
// the reference's lower bound, and the bracket is within the tolerance; where
// EPA runs out of vertices, the reported depth still separates the shapes.
#include <gtest/gtest.h>

#include <cmath>

#include "hbp/benchdata/random_pairs.hpp"
#include "hbp/narrow/convex.hpp"
#include "hbp/narrow/epa.hpp"
#include "hbp/narrow/gjk.hpp"
#include "hbp/narrow/intersect.hpp"

namespace hbp {
namespace {

constexpr ShapeKind kKinds[] = {ShapeKind::Sphere, ShapeKind::Cuboid, ShapeKind::Cylinder, ShapeKind::Cone};

TEST(EpaPolytope, BracketIsCertifiedAgainstATighterEpa) {
  ShapePairGenerator gen(23);
  narrow::EpaOptions fast;
  fast.rel_tolerance = narrow::kContactDepthTolerance;
  narrow::EpaOptions tight;
  tight.rel_tolerance = 1e-7;
  int checked = 0;
  for (ShapeKind ka : kKinds) {
    for (ShapeKind kb : kKinds) {
      for (int i = 0; i < 150; ++i) {
        const ShapePair p = gen.next(ka, kb);
        const narrow::Convex a = narrow::make_convex(p.a), b = narrow::make_convex(p.b);
        const narrow::GjkResult g = narrow::gjk(a, b);
        if (!g.intersecting) continue;
        const narrow::EpaResult r = narrow::epa(a, b, g.simplex, fast);
        const narrow::EpaResult ref = narrow::epa(a, b, g.simplex, tight);
        ASSERT_TRUE(r.ok && ref.ok);
        if (!r.converged || !ref.converged) continue;
        ++checked;
        const double scale = narrow::pair_scale(a, b);
        const double hair = 1e-12 * scale;  // rounding of a plane offset
        const char* kinds = shape_kind_name(ka);
        // lower <= true depth <= ref.depth; ref.lower_bound <= true depth <= depth.
        EXPECT_LE(r.lower_bound, ref.depth + hair) << kinds << "-" << shape_kind_name(kb);
        EXPECT_GE(r.depth, ref.lower_bound - hair) << kinds << "-" << shape_kind_name(kb);
        EXPECT_LE(r.depth - r.lower_bound,
                  fast.rel_tolerance * r.lower_bound + fast.abs_tolerance * scale + hair)
            << kinds << "-" << shape_kind_name(kb);
        EXPECT_NEAR(narrow::norm(r.normal), 1.0, 1e-12);
      }
    }
  }
  EXPECT_GT(checked, 900) << checked;
}

TEST(EpaPolytope, OutOfVerticesStillReportsASeparatingDepth) {
  // Two nearly concentric, nearly equal ellipsoids: D is almost a sphere
  // about the origin, the hardest case for EPA (it may stop at its vertex
  // capacity). Whatever it reports must separate the shapes.
  Shape a, b;
  a.kind = b.kind = ShapeKind::Sphere;
  a.size = {50.0, 50.2, 49.9};
  b.size = {50.1, 49.8, 50.0};
  a.position = {0, 0, 0};
  b.position = {0.01, -0.02, 0.005};
  b.orientation = normalized(Quat{0.1, 0.2, 0.3, 0.9});
  const narrow::Convex ca = narrow::make_convex(a), cb = narrow::make_convex(b);
  const narrow::GjkResult g = narrow::gjk(ca, cb);
  ASSERT_TRUE(g.intersecting);
  narrow::EpaOptions o;
  o.rel_tolerance = 1e-12;  // unreachable: EPA stops at its capacity
  const narrow::EpaResult r = narrow::epa(ca, cb, g.simplex, o);
  ASSERT_TRUE(r.ok);
  EXPECT_FALSE(r.converged);
  EXPECT_GT(r.iterations, 150);
  EXPECT_GT(r.depth, 40.0);
  EXPECT_LE(r.lower_bound, r.depth);
  Shape moved = b;
  moved.position.x += r.normal.x * r.depth * (1 + 1e-9);
  moved.position.y += r.normal.y * r.depth * (1 + 1e-9);
  moved.position.z += r.normal.z * r.depth * (1 + 1e-9);
  EXPECT_FALSE(intersect(a, moved));
}

}  // namespace
}  // namespace hbp
