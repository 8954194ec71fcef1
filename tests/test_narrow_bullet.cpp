// SPDX-License-Identifier: MIT
// Agreement of the narrow phase with an independent implementation: Bullet's
// GJK/EPA (btGjkEpaSolver2, single precision, zero margins) on Bullet's own
// primitives, over random pairs of every kind combination, random
// orientations, half of them placed within 1e-7 .. 1e-2 (relative) of
// touching. See docs/narrow-phase.md for the tolerance band.
//
// HBP_NARROW_PAIRS overrides the number of pairs (default 20,000, about 5 s;
// HBP_NARROW_PAIRS=100000 runs the full sweep of the issue, about 25 s).
#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <initializer_list>
#include <string>
#include <vector>

#include "hbp/baselines/bullet_shape_pair_test.hpp"
#include "hbp/narrow/convex.hpp"
#include "hbp/narrow/intersect.hpp"
#include "hbp/benchdata/random_pairs.hpp"

namespace hbp {
namespace {

constexpr ShapeKind kKinds[] = {ShapeKind::Sphere, ShapeKind::Cuboid, ShapeKind::Cylinder, ShapeKind::Cone};

double dotv(const Vec3& a, const Vec3& b) { return a.x * b.x + a.y * b.y + a.z * b.z; }

// Tolerance band near touching: Bullet's GJK declares contact below
// GJK_MIN_DISTANCE = 1e-4 (absolute, metres) and works in float (inputs
// rounded to about 6e-8 relative of the coordinates, up to 130 m here).
constexpr double kBandAbs = 1e-4;
constexpr double kBandRel = 2e-6;  // of the pair's scale (sum of bounding radii)

// Independent membership test from each shape's implicit inequalities (not
// its support mapping): is p inside s, with a relative tolerance?
bool contains(const Shape& s, const Vec3& p, double tol = 1e-9) {
  double r[3][3];
  rotation_matrix(normalized(s.orientation), r);
  const double d[3] = {p.x - s.position.x, p.y - s.position.y, p.z - s.position.z};
  double l[3];
  for (int j = 0; j < 3; ++j) l[j] = r[0][j] * d[0] + r[1][j] * d[1] + r[2][j] * d[2];
  const double hx = s.size.x / 2, hy = s.size.y / 2, hz = s.size.z / 2;
  const double ex = l[0] / hx, ey = l[1] / hy, ez = l[2] / hz;
  switch (s.kind) {
    case ShapeKind::Sphere: return ex * ex + ey * ey + ez * ez <= 1 + tol;
    case ShapeKind::Cuboid: return std::fabs(ex) <= 1 + tol && std::fabs(ey) <= 1 + tol && std::fabs(ez) <= 1 + tol;
    case ShapeKind::Cylinder: return std::fabs(ez) <= 1 + tol && ex * ex + ey * ey <= 1 + tol;
    case ShapeKind::Cone: {
      const double rad = (1 - ez) / 2;  // 1 at the base (z = -h), 0 at the apex
      return std::fabs(ez) <= 1 + tol && ex * ex + ey * ey <= rad * rad + tol;
    }
  }
  return false;
}

// True if a point inside both shapes is found among candidates built from a
// contact of ours: the contact point and points between each shape's deepest
// point (its support point towards the other) and the far end of the overlap.
bool certify_overlap(const Shape& a, const Shape& b, const Contact& c) {
  if (contains(a, c.point) && contains(b, c.point)) return true;
  const Vec3 n = c.normal, m{-n.x, -n.y, -n.z};
  const Vec3 sa = support_point(a, n), sb = support_point(b, m);
  for (double t : {0.001, 0.1, 0.25, 0.5, 0.75, 0.9, 0.999}) {
    const double d = t * c.depth;
    const Vec3 pb{sb.x + n.x * d, sb.y + n.y * d, sb.z + n.z * d};
    const Vec3 pa{sa.x - n.x * d, sa.y - n.y * d, sa.z - n.z * d};
    if (contains(a, pb) && contains(b, pb)) return true;
    if (contains(a, pa) && contains(b, pa)) return true;
  }
  return false;
}

Shape moved(Shape s, const Vec3& n, double t) {
  s.position = {s.position.x + n.x * t, s.position.y + n.y * t, s.position.z + n.z * t};
  return s;
}
// Depths: relative 1e-3, plus an absolute floor for shallow contacts where
// float rounding and Bullet's EPA accuracy (1e-4 absolute) dominate.
constexpr double kDepthRel = 1e-3;
constexpr double kDepthAbs = 5e-4;  // metres

std::size_t pair_count() {
  if (const char* env = std::getenv("HBP_NARROW_PAIRS")) return std::strtoul(env, nullptr, 10);
  return 20000;
}

TEST(NarrowBullet, SupportMappingsMatch) {
  // Same shape in both libraries: support values agree to float precision
  // (checks the cone's apex convention and the elliptic wrappers).
  ShapePairGenerator gen(21);
  for (int i = 0; i < 4000; ++i) {
    const ShapePair p = gen.next();
    const Vec3 d{p.b.position.x - p.a.position.x, p.b.position.y - p.a.position.y,
                 p.b.position.z - p.a.position.z};
    const double len = std::sqrt(dotv(d, d));
    const Vec3 u{d.x / len, d.y / len, d.z / len};
    const double ours = dotv(support_point(p.a, u), u) - dotv(p.a.position, u);
    const double bullet = dotv(baselines::bullet_support_point(p.a, u), u) - dotv(p.a.position, u);
    ASSERT_NEAR(ours, bullet, 2e-5 * 100) << shape_kind_name(p.a.kind) << " size " << p.a.size.x << " "
                                          << p.a.size.y << " " << p.a.size.z;
  }
}

struct ComboStats {
  std::size_t pairs = 0, hits = 0, misses = 0;
  std::size_t disagree_in_band = 0, disagree_out_of_band = 0;
  std::size_t bullet_missed_certified = 0;  // ours: a point inside both shapes
  std::size_t bullet_short_certified = 0;   // Bullet's translation leaves a common point
  std::size_t libccd_sides_with_ours = 0;   // libccd's MPR and GJK both agree with ours
  std::size_t bullet_failed = 0;
  std::size_t depth_compared = 0, depth_within_rel = 0, depth_out = 0;
  double max_depth_rel = 0;   // over depths >= 1 m
  double max_band_seen = 0;   // |signed distance| / scale of disagreements
  double min_normal_dot = 1;  // over depths >= 1 m
};

TEST(NarrowBullet, AgreesOnRandomPairs) {
  const std::size_t total = pair_count();
  const std::size_t per_combo = std::max<std::size_t>(1, total / 16);
  ShapePairGenerator gen(2024);
  ComboStats all;
  std::printf("%-18s %7s %7s %7s %6s %6s %6s %6s %6s %6s %9s %10s %9s\n", "kinds", "pairs", "hits", "misses", "band",
              "bmiss", "ccd", "out", "bshort", "bfail", "depth_n", "max_rel", "min_ndot");
  for (ShapeKind ka : kKinds) {
    for (ShapeKind kb : kKinds) {
      ComboStats st;
      for (std::size_t i = 0; i < per_combo; ++i) {
        const ShapePair p = gen.next(ka, kb);
        const double scale = narrow::make_convex(p.a).radius + narrow::make_convex(p.b).radius;
        Contact c;
        const bool ours = intersect(p.a, p.b, &c);
        const baselines::BulletPairResult ref = baselines::bullet_shape_pair_test(p.a, p.b);
        ++st.pairs;
        st.bullet_failed += ref.failed;
        if (ours != ref.intersecting) {
          const double sd = std::fabs(signed_distance(p.a, p.b));
          if (sd <= kBandAbs + kBandRel * scale) {
            ++st.disagree_in_band;
            st.max_band_seen = std::max(st.max_band_seen, sd);
          } else if (ours && certify_overlap(p.a, p.b, c)) {
            ++st.bullet_missed_certified;
          } else if (ours == intersect(p.a, p.b, nullptr, NarrowMethod::LibccdMpr) &&
                     ours == intersect(p.a, p.b, nullptr, NarrowMethod::LibccdGjkEpa)) {
            ++st.libccd_sides_with_ours;
          } else {
            ++st.disagree_out_of_band;
            ADD_FAILURE() << shape_kind_name(ka) << "-" << shape_kind_name(kb) << " ours " << ours << " bullet "
                          << ref.intersecting << " |sd| " << sd << " near_rel " << p.near_rel;
          }
          continue;
        }
        if (!ours) {
          ++st.misses;
          continue;
        }
        ++st.hits;
        const double db = -ref.signed_distance;
        ++st.depth_compared;
        const double diff = std::fabs(c.depth - db);
        const double big = std::max(c.depth, db);
        if (diff <= kDepthRel * big) ++st.depth_within_rel;
        if (diff > kDepthRel * big + kDepthAbs) {
          // Bullet's EPA stopping short (float, 128 vertices, 1e-4 accuracy)
          // is certified when moving b by Bullet's normal * depth still
          // leaves a point inside both shapes.
          const Shape b2 = moved(p.b, ref.normal, db * (1 + 1e-6));
          Contact c2;
          // (A Bullet depth of ~0 — its EPA fell back to touching — is short
          // if our contact's overlap is certified.)
          if ((db <= kDepthAbs && certify_overlap(p.a, p.b, c)) ||
              (db < c.depth && intersect(p.a, b2, &c2) && certify_overlap(p.a, b2, c2))) {
            ++st.bullet_short_certified;
            continue;
          }
          // Or Bullet contradicts itself: on the moved pair it still reports
          // a penetration beyond the depth floor.
          const baselines::BulletPairResult again = baselines::bullet_shape_pair_test(p.a, b2);
          if (db < c.depth && again.intersecting && -again.signed_distance > kDepthAbs) {
            ++st.bullet_short_certified;
            continue;
          }
          ++st.depth_out;
          std::printf("uncertified depth difference: %s-%s ours %.9g bullet %.9g\n", shape_kind_name(ka),
                      shape_kind_name(kb), c.depth, db);
        }
        if (big >= 1.0) {
          st.max_depth_rel = std::max(st.max_depth_rel, diff / big);
          st.min_normal_dot = std::min(st.min_normal_dot, dotv(c.normal, ref.normal));
        }
      }
      const std::string name = std::string(shape_kind_name(ka)) + "-" + shape_kind_name(kb);
      std::printf("%-18s %7zu %7zu %7zu %6zu %6zu %6zu %6zu %6zu %6zu %9zu %10.2e %9.6f\n", name.c_str(), st.pairs,
                  st.hits, st.misses, st.disagree_in_band, st.bullet_missed_certified, st.libccd_sides_with_ours,
                  st.disagree_out_of_band,
                  st.bullet_short_certified, st.bullet_failed, st.depth_compared, st.max_depth_rel, st.min_normal_dot);
      all.pairs += st.pairs;
      all.hits += st.hits;
      all.misses += st.misses;
      all.disagree_in_band += st.disagree_in_band;
      all.disagree_out_of_band += st.disagree_out_of_band;
      all.bullet_failed += st.bullet_failed;
      all.bullet_missed_certified += st.bullet_missed_certified;
      all.bullet_short_certified += st.bullet_short_certified;
      all.libccd_sides_with_ours += st.libccd_sides_with_ours;
      all.depth_compared += st.depth_compared;
      all.depth_within_rel += st.depth_within_rel;
      all.depth_out += st.depth_out;
      all.max_depth_rel = std::max(all.max_depth_rel, st.max_depth_rel);
      all.max_band_seen = std::max(all.max_band_seen, st.max_band_seen);
      all.min_normal_dot = std::min(all.min_normal_dot, st.min_normal_dot);
    }
  }
  std::printf("%-18s %7zu %7zu %7zu %6zu %6zu %6zu %6zu %6zu %6zu %9zu %10.2e %9.6f\n", "all", all.pairs, all.hits,
              all.misses, all.disagree_in_band, all.bullet_missed_certified, all.libccd_sides_with_ours,
              all.disagree_out_of_band,
              all.bullet_short_certified, all.bullet_failed, all.depth_compared, all.max_depth_rel, all.min_normal_dot);
  std::printf("depths within 1e-3 relative: %zu of %zu (%.4f%%); outside rel+abs floor: %zu; widest |sd| of an "
              "in-band disagreement: %.2e m\n",
              all.depth_within_rel, all.depth_compared, 100.0 * all.depth_within_rel / std::max<std::size_t>(1, all.depth_compared),
              all.depth_out, all.max_band_seen);
  EXPECT_EQ(all.pairs, per_combo * 16);
  EXPECT_EQ(all.disagree_out_of_band, 0u);
  // At most 1 in 10,000 compared depths outside 1e-3 relative + 5e-4 m and not
  // certified as a Bullet shortfall (the 100,000-pair sweep has 1: a
  // cone-cuboid pair at 0.2437 vs 0.2426 m; see docs/narrow-phase.md).
  EXPECT_LE(all.depth_out * 10000, all.depth_compared);
  // Both outcomes well represented in every run.
  EXPECT_GT(all.hits, all.pairs / 4);
  EXPECT_GT(all.misses, all.pairs / 4);
}

}  // namespace
}  // namespace hbp
