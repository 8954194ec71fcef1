// SPDX-License-Identifier: MIT
// Narrow phase: support mapping, closed forms against hand-computed values,
// GJK/EPA against the closed forms, separation by the reported depth, the
// cone's apex convention, symmetry, libccd, and the NarrowPhase batch API.
#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <random>
#include <string>
#include <vector>

#include "hbp/error.hpp"
#include "hbp/narrow/closed_forms.hpp"
#include "hbp/narrow/convex.hpp"
#include "hbp/narrow/epa.hpp"
#include "hbp/narrow/gjk.hpp"
#include "hbp/narrow/intersect.hpp"
#include "hbp/narrow/libccd_solver.hpp"
#include "hbp/narrow/narrow_phase.hpp"
#include "hbp/benchdata/random_pairs.hpp"

namespace hbp {
namespace {

Shape make(ShapeKind kind, Vec3 size, Vec3 pos, Quat q = {}) {
  Shape s;
  s.kind = kind;
  s.size = size;
  s.position = pos;
  s.orientation = normalized(q);
  return s;
}

Shape translated(Shape s, const Vec3& n, double t) {
  s.position = {s.position.x + n.x * t, s.position.y + n.y * t, s.position.z + n.z * t};
  return s;
}

double dotv(const Vec3& a, const Vec3& b) { return a.x * b.x + a.y * b.y + a.z * b.z; }

constexpr ShapeKind kKinds[] = {ShapeKind::Sphere, ShapeKind::Cuboid, ShapeKind::Cylinder, ShapeKind::Cone};

TEST(NarrowSupport, MatchesGeometrySupportPoint) {
  ShapePairGenerator gen(11);
  for (int i = 0; i < 400; ++i) {
    const ShapePair p = gen.next();
    const narrow::Convex c = narrow::make_convex(p.a);
    const ShapePair q = gen.next();
    const Vec3 d{q.b.position.x - q.a.position.x, q.b.position.y - q.a.position.y, q.b.position.z - q.a.position.z};
    const Vec3 ref = support_point(p.a, d);
    const narrow::V3 got = c.support(narrow::to_v3(d));
    // Same support value (the point itself may differ on flat features).
    EXPECT_NEAR(dotv(narrow::to_vec3(got), d), dotv(ref, d), 1e-9 * std::sqrt(dotv(d, d)) * 200);
  }
}

TEST(NarrowClosedForms, SphereSphereDepthNormalPoint) {
  const Shape a = make(ShapeKind::Sphere, {10, 10, 10}, {0, 0, 0});
  const Shape b = make(ShapeKind::Sphere, {6, 6, 6}, {0, 7, 0});
  Contact c;
  ASSERT_TRUE(intersect(a, b, &c));
  EXPECT_DOUBLE_EQ(c.depth, 1.0);  // 5 + 3 - 7
  EXPECT_DOUBLE_EQ(c.normal.y, 1.0);
  EXPECT_DOUBLE_EQ(c.point.y, 4.5);  // between y = 5 (a) and y = 4 (b)
  EXPECT_FALSE(intersect(a, make(ShapeKind::Sphere, {6, 6, 6}, {0, 8.000001, 0})));
  EXPECT_TRUE(intersect(a, make(ShapeKind::Sphere, {6, 6, 6}, {0, 8, 0})));  // touching counts
}

TEST(NarrowClosedForms, BoxSphereOutsideAndInside) {
  const Shape box = make(ShapeKind::Cuboid, {4, 6, 8}, {1, 1, 1});
  // Sphere centre beyond the +x face, level with the face's interior.
  Contact c;
  ASSERT_TRUE(intersect(box, make(ShapeKind::Sphere, {2, 2, 2}, {3.5, 1, 1}), &c));
  EXPECT_NEAR(c.depth, 0.5, 1e-12);
  EXPECT_NEAR(c.normal.x, 1.0, 1e-12);
  // Near the corner (3, 4, 5): distance sqrt(3) * 0.5.
  const double off = 0.5;
  ASSERT_TRUE(intersect(box, make(ShapeKind::Sphere, {2, 2, 2}, {3 + off, 4 + off, 5 + off}), &c));
  EXPECT_NEAR(c.depth, 1 - std::sqrt(3.0) * off, 1e-12);
  EXPECT_NEAR(c.normal.z, 1 / std::sqrt(3.0), 1e-12);
  // Centre inside, nearest face -y (room 0.5): depth r + 0.5; sphere first.
  ASSERT_TRUE(intersect(make(ShapeKind::Sphere, {2, 2, 2}, {1, -1.5, 1}), box, &c));
  EXPECT_NEAR(c.depth, 1.5, 1e-12);
  EXPECT_NEAR(c.normal.y, 1.0, 1e-12);  // from the sphere towards the box
  EXPECT_FALSE(intersect(box, make(ShapeKind::Sphere, {2, 2, 2}, {4.01, 1, 1})));
}

TEST(NarrowClosedForms, BoxBoxFaceAndEdge) {
  const Shape a = make(ShapeKind::Cuboid, {2, 2, 2}, {0, 0, 0});
  Contact c;
  ASSERT_TRUE(intersect(a, make(ShapeKind::Cuboid, {2, 4, 2}, {0.3, 0.2, 1.75}), &c));
  EXPECT_NEAR(c.depth, 0.25, 1e-12);
  EXPECT_NEAR(c.normal.z, 1.0, 1e-12);
  EXPECT_NEAR(c.point.z, 0.875, 1e-12);
  // b rotated 45 degrees about x and about z: its lower edge meets a's top
  // face... check against GJK/EPA for the depth and normal.
  const Quat q = multiply(Quat{std::cos(0.3927), 0, 0, std::sin(0.3927)}, Quat{std::cos(0.3927), std::sin(0.3927), 0, 0});
  const Shape b = make(ShapeKind::Cuboid, {2, 2, 2}, {0.5, 0.4, 2.2}, q);
  Contact e;
  ASSERT_TRUE(intersect(a, b, &c, NarrowMethod::Auto));
  ASSERT_TRUE(intersect(a, b, &e, NarrowMethod::GjkEpa));
  EXPECT_NEAR(c.depth, e.depth, 1e-7);
  EXPECT_GT(dotv(c.normal, e.normal), 1 - 1e-9);
  EXPECT_FALSE(intersect(a, make(ShapeKind::Cuboid, {2, 2, 2}, {0, 0, 2.74}, q)));
}

TEST(NarrowGjkEpa, AgreesWithClosedForms) {
  // Pairs where a closed form applies: GJK/EPA must give the same answers.
  ShapePairOptions o;
  o.circular_fraction = 1.0;  // true spheres
  ShapePairGenerator gen(5, o);
  const std::pair<ShapeKind, ShapeKind> combos[] = {{ShapeKind::Sphere, ShapeKind::Sphere},
                                                    {ShapeKind::Cuboid, ShapeKind::Sphere},
                                                    {ShapeKind::Sphere, ShapeKind::Cuboid},
                                                    {ShapeKind::Cuboid, ShapeKind::Cuboid}};
  int hits = 0;
  for (const auto& [ka, kb] : combos) {
    for (int i = 0; i < 500; ++i) {
      const ShapePair p = gen.next(ka, kb);
      Contact c, e;
      const bool rc = intersect(p.a, p.b, &c, NarrowMethod::Auto);
      const bool re = intersect(p.a, p.b, &e, NarrowMethod::GjkEpa);
      const double scale = 100;
      if (rc != re) {
        // Only within a hair of touching.
        EXPECT_LT(std::fabs(signed_distance(p.a, p.b)), 1e-8 * scale) << shape_kind_name(ka) << shape_kind_name(kb);
        continue;
      }
      if (!rc) continue;
      ++hits;
      EXPECT_NEAR(c.depth, e.depth, narrow::kContactDepthTolerance * c.depth + 1e-8 * scale) << shape_kind_name(ka) << "-" << shape_kind_name(kb);
      if (c.depth > 1e-3) {
        // A depth within a relative t of the optimum leaves the normal within
        // about sqrt(2 t depth / radius) rad of the optimal one: 1 - cos of
        // that is t times depth / radius, below 10 t on these pairs.
        EXPECT_GT(dotv(c.normal, e.normal), 1 - 10 * narrow::kContactDepthTolerance);
      }
    }
  }
  EXPECT_GT(hits, 800);
}

TEST(NarrowGjkEpa, SphereDistanceExact) {
  const Shape a = make(ShapeKind::Sphere, {10, 10, 10}, {0, 0, 0});
  const Shape b = make(ShapeKind::Sphere, {4, 4, 4}, {3, 4, 12});  // |d| = 13
  EXPECT_NEAR(signed_distance(a, b), 13 - 7, 1e-8);
  const Shape c = make(ShapeKind::Sphere, {4, 4, 4}, {3, 4, 0});  // |d| = 5
  EXPECT_NEAR(signed_distance(a, c), -(7 - 5), 1e-6);
}

TEST(NarrowGjkEpa, EllipsoidAlongAxis) {
  // Ellipsoids touching along x: semi-axes 10 and 4 -> touching at 14.
  const Shape a = make(ShapeKind::Sphere, {20, 8, 6}, {0, 0, 0});
  EXPECT_TRUE(intersect(a, make(ShapeKind::Sphere, {8, 30, 30}, {14 - 1e-7, 0, 0})));
  EXPECT_FALSE(intersect(a, make(ShapeKind::Sphere, {8, 30, 30}, {14 + 1e-7, 0, 0})));
  EXPECT_NEAR(signed_distance(a, make(ShapeKind::Sphere, {8, 30, 30}, {16, 0, 0})), 2.0, 1e-7);
}

TEST(NarrowGjkEpa, ConeApexAtPlusZ) {
  // Cone of height 10 (apex z = +5, base z = -5, base radius 4); a tiny cube
  // probing just above and below the apex, and beside the base rim.
  const Shape cone = make(ShapeKind::Cone, {8, 8, 10}, {0, 0, 0});
  const Vec3 s{0.02, 0.02, 0.02};
  EXPECT_TRUE(intersect(cone, make(ShapeKind::Cuboid, s, {0, 0, 5.005})));
  EXPECT_FALSE(intersect(cone, make(ShapeKind::Cuboid, s, {0, 0, 5.02})));
  EXPECT_FALSE(intersect(cone, make(ShapeKind::Cuboid, s, {0, 0, -5.02})));
  EXPECT_TRUE(intersect(cone, make(ShapeKind::Cuboid, s, {3.995, 0, -4.995})));
  EXPECT_FALSE(intersect(cone, make(ShapeKind::Cuboid, s, {3.995, 0, 4.0})));  // beside the apex
}

TEST(NarrowGjkEpa, DepthSeparatesAndIsMinimalAlongNormal) {
  // Moving b by (1 + 1e-6) * depth along the normal separates the pair;
  // moving it by (1 - 1e-3) * depth does not.
  ShapePairOptions o;
  o.near_fraction = 0;
  ShapePairGenerator gen(7, o);
  int checked = 0;
  for (ShapeKind ka : kKinds) {
    for (ShapeKind kb : kKinds) {
      for (int i = 0; i < 60; ++i) {
        const ShapePair p = gen.next(ka, kb);
        Contact c;
        if (!intersect(p.a, p.b, &c) || c.depth < 1e-3) continue;
        ++checked;
        EXPECT_NEAR(dotv(c.normal, c.normal), 1.0, 1e-12);
        EXPECT_FALSE(intersect(p.a, translated(p.b, c.normal, c.depth * (1 + 1e-6) + 1e-9)))
            << shape_kind_name(ka) << "-" << shape_kind_name(kb) << " depth " << c.depth;
        EXPECT_TRUE(intersect(p.a, translated(p.b, c.normal, c.depth * (1 - 1e-3))))
            << shape_kind_name(ka) << "-" << shape_kind_name(kb) << " depth " << c.depth;
      }
    }
  }
  EXPECT_GT(checked, 400);
}

TEST(NarrowGjkEpa, SymmetricInArgumentOrder) {
  ShapePairGenerator gen(9);
  for (int i = 0; i < 1000; ++i) {
    const ShapePair p = gen.next();
    Contact ab, ba;
    const bool r1 = intersect(p.a, p.b, &ab), r2 = intersect(p.b, p.a, &ba);
    if (r1 != r2) {
      EXPECT_LT(std::fabs(signed_distance(p.a, p.b)), 1e-8);
      continue;
    }
    if (!r1) continue;
    EXPECT_NEAR(ab.depth, ba.depth, 2 * narrow::kContactDepthTolerance * ab.depth + 1e-8);
    if (ab.depth > 1e-3) {
      EXPECT_LT(dotv(ab.normal, ba.normal), -0.999);
    }
  }
}

TEST(NarrowGjkEpa, ContactPointMidwayBetweenSupportPoints) {
  // point +- normal * depth / 2 are the deepest points of a and b: a's
  // support along the normal and b's support against it, and the depth is
  // the Minkowski difference's support value h_A(n) + h_B(-n) along it.
  ShapePairOptions o;
  o.near_fraction = 0;
  ShapePairGenerator gen(13, o);
  int checked = 0;
  for (int i = 0; i < 1500; ++i) {
    const ShapePair p = gen.next();
    Contact c;
    if (!intersect(p.a, p.b, &c) || c.depth < 0.5) continue;
    ++checked;
    const Vec3 n = c.normal, m{-n.x, -n.y, -n.z};
    const Vec3 pa{c.point.x + n.x * c.depth / 2, c.point.y + n.y * c.depth / 2, c.point.z + n.z * c.depth / 2};
    const Vec3 pb{c.point.x - n.x * c.depth / 2, c.point.y - n.y * c.depth / 2, c.point.z - n.z * c.depth / 2};
    const double ha = dotv(support_point(p.a, n), n), hb = dotv(support_point(p.b, m), m);
    const std::string what = std::string(shape_kind_name(p.a.kind)) + "-" + shape_kind_name(p.b.kind);
    EXPECT_NEAR(dotv(pa, n), ha, 1e-3 + 2 * narrow::kContactDepthTolerance * c.depth) << what;
    EXPECT_NEAR(dotv(pb, m), hb, 1e-3 + 2 * narrow::kContactDepthTolerance * c.depth) << what;
    EXPECT_NEAR(c.depth, ha + hb, 2 * narrow::kContactDepthTolerance * c.depth) << what;
  }
  EXPECT_GT(checked, 500);
}

TEST(NarrowLibccd, BooleanAgreesAwayFromTouching) {
  ASSERT_TRUE(narrow::libccd_available());
  ShapePairGenerator gen(17);
  int compared = 0, hits = 0;
  for (int i = 0; i < 2000; ++i) {
    const ShapePair p = gen.next();
    const double sd = signed_distance(p.a, p.b);
    if (std::fabs(sd) < 1e-6 * 100) continue;
    ++compared;
    const bool ours = intersect(p.a, p.b);
    hits += ours;
    EXPECT_EQ(ours, intersect(p.a, p.b, nullptr, NarrowMethod::LibccdMpr)) << "sd " << sd;
    EXPECT_EQ(ours, intersect(p.a, p.b, nullptr, NarrowMethod::LibccdGjkEpa)) << "sd " << sd;
  }
  EXPECT_GT(compared, 1500);
  EXPECT_GT(hits, 300);
}

TEST(NarrowPhaseBatch, ProcessReportsCollidingPairsInOrder) {
  std::vector<Shape> shapes = {
      make(ShapeKind::Sphere, {2, 2, 2}, {0, 0, 0}), make(ShapeKind::Cuboid, {2, 2, 2}, {1.5, 0, 0}),
      make(ShapeKind::Cone, {2, 2, 2}, {10, 0, 0}), make(ShapeKind::Cylinder, {2, 2, 2}, {10, 0, 1.5})};
  const std::vector<Pair> pairs = {{0, 1}, {0, 2}, {1, 2}, {2, 3}};
  std::vector<Contact> out;
  NarrowPhase narrow;
  EXPECT_EQ(narrow.process(shapes, pairs.data(), pairs.size(), out), 2u);
  ASSERT_EQ(out.size(), 2u);
  EXPECT_EQ(out[0].a, 0u);
  EXPECT_EQ(out[0].b, 1u);
  EXPECT_NEAR(out[0].depth, 0.5, 1e-12);
  EXPECT_EQ(out[1].a, 2u);
  EXPECT_EQ(out[1].b, 3u);
  EXPECT_NEAR(out[1].depth, 0.5, 1e-6);  // cylinder bottom face meets the apex
  EXPECT_NEAR(out[1].normal.z, 1.0, 1e-6);
  const std::vector<Pair> bad = {{0, 9}};
  EXPECT_THROW(narrow.process(shapes, bad.data(), bad.size(), out), InvalidInput);
  NarrowPhase boolean_only({.method = NarrowMethod::Auto, .contacts = false});
  std::vector<Contact> out2;
  EXPECT_EQ(boolean_only.process(shapes, pairs.data(), pairs.size(), out2), 2u);
}

TEST(NarrowPhaseBatch, DepthToleranceOutOfRangeThrows) {
  for (const double t : {0.0, -1e-4, 0.2, std::nan(""), HUGE_VAL, 1e-12}) {
    EXPECT_THROW(NarrowPhase({.depth_tolerance = t}), InvalidInput) << t;
  }
  EXPECT_NO_THROW(NarrowPhase({.depth_tolerance = narrow::kMinDepthTolerance}));
  EXPECT_NO_THROW(NarrowPhase({.depth_tolerance = narrow::kMaxDepthTolerance}));
}

// The option reaches EPA: on curved pairs (no closed form) the default's
// depths lie above a fine run's by up to the default tolerance, some by more
// than the fine one allows, never below it; verdicts do not change.
TEST(NarrowPhaseBatch, DepthToleranceTakesEffect) {
  ShapePairOptions o;
  o.circular_fraction = 0.0;  // no true spheres: GJK + EPA on every pair
  ShapePairGenerator gen(21, o);
  const NarrowPhase coarse, fine({.depth_tolerance = 1e-7});
  EXPECT_EQ(coarse.options().depth_tolerance, narrow::kContactDepthTolerance);
  int compared = 0, coarser = 0;
  for (int i = 0; i < 600; ++i) {
    const ShapePair p = gen.next(ShapeKind::Sphere, i % 2 ? ShapeKind::Cylinder : ShapeKind::Cone);
    const std::vector<Shape> two = {p.a, p.b};
    const Pair first_second{0, 1};
    std::vector<Contact> c, f;
    ASSERT_EQ(coarse.process(two, &first_second, 1, c), fine.process(two, &first_second, 1, f)) << i;
    if (c.empty() || f[0].depth < 1e-2) continue;
    ++compared;
    const double excess = (c[0].depth - f[0].depth) / f[0].depth;
    EXPECT_GE(excess, -2e-7) << i;  // both are upper ends of the true depth
    EXPECT_LE(excess, narrow::kContactDepthTolerance + 2e-7) << i;
    coarser += excess > 1e-5;
  }
  EXPECT_GT(compared, 150);
  EXPECT_GT(coarser, compared / 10);  // 1e-7 would never leave them this far apart
}

}  // namespace
}  // namespace hbp

namespace hbp {
namespace {

// An ellipsoid is its core plus a ball of radius core_radius: the core's
// support value plus that radius is the ellipsoid's in every direction, and
// the ball about any core support point stays inside the ellipsoid (fails
// if the radius were larger than the smallest radius of curvature, c^2/a).
TEST(NarrowRoundedCores, CorePlusItsBallIsTheEllipsoid) {
  std::mt19937_64 rng(5);
  std::uniform_real_distribution<double> size(5, 80), unit(-1, 1);
  for (int i = 0; i < 300; ++i) {
    const Quat q = normalized(Quat{unit(rng), unit(rng), unit(rng), unit(rng)});
    const Shape e = make(ShapeKind::Sphere, {size(rng), size(rng), size(rng)}, {unit(rng) * 50, 0, 3}, q);
    const narrow::Convex shape = narrow::make_convex(e);
    const narrow::Convex core = narrow::core_of(shape);
    const double hi = std::max({e.size.x, e.size.y, e.size.z}) / 2, lo = std::min({e.size.x, e.size.y, e.size.z}) / 2;
    ASSERT_NEAR(core.core_inset, lo * lo / hi, 1e-12 * hi);
    for (int k = 0; k < 20; ++k) {
      narrow::V3 d{unit(rng), unit(rng), unit(rng)};
      d = d * (1 / narrow::norm(d));
      const narrow::V3 p = core.support(d);
      EXPECT_NEAR(narrow::dot(p, d) + core.core_inset, narrow::dot(shape.support(d), d), 1e-9 * hi);
      // The ball about p: its point furthest along any unit u is inside.
      narrow::V3 u{unit(rng), unit(rng), unit(rng)};
      u = u * (1 / narrow::norm(u));
      const narrow::V3 x = p + core.core_inset * u - shape.centre;
      const narrow::V3 l = shape.to_local(x);
      const double f = (l.x / shape.h[0]) * (l.x / shape.h[0]) + (l.y / shape.h[1]) * (l.y / shape.h[1]) +
                       (l.z / shape.h[2]) * (l.z / shape.h[2]);
      EXPECT_LE(f, 1 + 1e-9) << "ellipsoid " << i;
    }
  }
  narrow::Convex box = narrow::make_convex(make(ShapeKind::Cuboid, {2, 3, 4}, {}));
  EXPECT_EQ(narrow::core_radius(box), 0);
}

// Pairs with an ellipsoid get their depth from the cores: EPA on the cores
// where the origin lies in their difference, GJK where it lies in the
// shell around it (both occur here). The depth is never below the true
// one (EPA on the shapes to 1e-9) and within the tolerance above it.
TEST(NarrowRoundedCores, DepthWithinToleranceInBothCases) {
  ShapePairOptions o;
  o.near_fraction = 0.3;
  ShapePairGenerator gen(11, o);
  int in_core = 0, in_shell = 0;
  for (ShapeKind kb : kKinds) {
    for (int i = 0; i < 150; ++i) {
      const ShapePair p = gen.next(ShapeKind::Sphere, kb);
      const narrow::Convex a = narrow::make_convex(p.a), b = narrow::make_convex(p.b);
      narrow::Hit hit;
      if (!narrow::intersect(a, b, &hit, NarrowMethod::Auto)) continue;
      const narrow::GjkResult g = narrow::gjk(a, b);
      narrow::EpaOptions tight;
      tight.rel_tolerance = 1e-9;
      const narrow::EpaResult reference = narrow::epa(a, b, g.simplex, tight);
      const double truth = reference.lower_bound;
      const double scale = narrow::pair_scale(a, b);
      EXPECT_GE(hit.depth, truth - 1e-9 * scale) << shape_kind_name(kb) << " " << i;
      if (reference.converged) {  // (EPA on two near-concentric curved shapes may stop short)
        EXPECT_LE(hit.depth, truth * (1 + narrow::kContactDepthTolerance) + 1e-9 * scale)
            << shape_kind_name(kb) << " " << i;
      }
      (narrow::gjk(narrow::core_of(a), narrow::core_of(b)).intersecting ? in_core : in_shell) += 1;
    }
  }
  EXPECT_GT(in_core, 50);
  EXPECT_GT(in_shell, 50);
}

}  // namespace
}  // namespace hbp

namespace hbp {
namespace {

// Needles, pancakes and specks against every kind (sizes log-uniform over
// four decades per axis): the verdict with contacts is the intersection-only
// one, moving b by the depth along the normal separates the pair, and the
// depth is never below the shapes' own EPA's lower bound.
TEST(NarrowRoundedCores, ExtremeEllipsoids) {
  std::mt19937_64 rng(21);
  std::uniform_real_distribution<double> exponent(-2, 2), unit(-1, 1);
  const auto size = [&] {
    return Vec3{std::pow(10.0, exponent(rng)), std::pow(10.0, exponent(rng)), std::pow(10.0, exponent(rng))};
  };
  int contacts = 0;
  for (ShapeKind kb : kKinds) {
    for (int i = 0; i < 400; ++i) {
      const Shape a = make(ShapeKind::Sphere, size(), {0, 0, 0}, Quat{unit(rng), unit(rng), unit(rng), unit(rng)});
      const Vec3 sb = size();
      const double reach = 0.5 * (std::max({a.size.x, a.size.y, a.size.z}) + std::max({sb.x, sb.y, sb.z}));
      // b's centre near a point of a (its local box, scaled by 1.2).
      const narrow::V3 at = narrow::make_convex(a).to_world(
          {0.6 * unit(rng) * a.size.x, 0.6 * unit(rng) * a.size.y, 0.6 * unit(rng) * a.size.z});
      const Shape b = make(kb, sb, {at.x, at.y, at.z}, Quat{unit(rng), unit(rng), unit(rng), unit(rng)});
      Contact c;
      const bool hit = intersect(a, b, &c);
      ASSERT_EQ(hit, intersect(a, b)) << shape_kind_name(kb) << " " << i;
      if (!hit) continue;
      ++contacts;
      EXPECT_FALSE(intersect(a, translated(b, c.normal, c.depth * (1 + 1e-6) + 1e-9 * reach)))
          << shape_kind_name(kb) << " " << i << " depth " << c.depth;
      const narrow::Convex ca = narrow::make_convex(a), cb = narrow::make_convex(b);
      const narrow::GjkResult g = narrow::gjk(ca, cb);
      if (!g.intersecting) continue;  // touching within GJK's tolerance
      EXPECT_GE(c.depth, narrow::epa(ca, cb, g.simplex).lower_bound - 1e-9 * reach) << shape_kind_name(kb) << " " << i;
    }
  }
  EXPECT_GT(contacts, 400);
}

}  // namespace
}  // namespace hbp
