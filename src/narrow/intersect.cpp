// SPDX-License-Identifier: MIT
#include "hbp/narrow/intersect.hpp"

#include <cmath>
#include <tuple>

#include "hbp/narrow/closed_forms.hpp"
#include "hbp/narrow/epa.hpp"
#include "hbp/narrow/gjk.hpp"
#include "hbp/narrow/libccd_solver.hpp"
#include "hbp/narrow/obb_reject.hpp"

namespace hbp {

const char* narrow_method_name(NarrowMethod method) {
  switch (method) {
    case NarrowMethod::Auto: return "auto";
    case NarrowMethod::GjkEpa: return "gjk-epa";
    case NarrowMethod::LibccdMpr: return "libccd-mpr";
    case NarrowMethod::LibccdGjkEpa: return "libccd-gjk-epa";
  }
  return "unknown";
}

namespace narrow {

namespace {

// Half-angle of the cone tetrahedron (radians) as its cosine and sine, the
// angle that needs the fewest instructions on the warm path at the default
// depth tolerance (bench_epa under callgrind): 0.25 on the shapes; 0.06 on
// the rounded cores, whose difference is far less round near the optimum.
struct ConeAngle {
  double cos, sin;
};
const ConeAngle kShapesCone{std::cos(0.25), std::sin(0.25)};
const ConeAngle kCoresCone{std::cos(0.06), std::sin(0.06)};

// A tetrahedron around last frame's contact normal n: three directions
// tilted from n by the cone's angle (120 degrees apart), and a fourth away
// from their support points. If they enclose the origin, the face of the
// first three lies almost square to the contact normal, near the deepest
// point, and EPA starts there.
Simplex cone_tetrahedron(const Convex& a, const Convex& b, const V3& n, const ConeAngle& angle) {
  // Any unit vector square to n, then a right-handed frame (n, e1, e2).
  const V3 t = std::fabs(n.x) < 0.6 ? V3{1, 0, 0} : V3{0, 1, 0};
  const V3 c = cross(n, t);
  const V3 e1 = c * (1.0 / norm(c)), e2 = cross(n, e1);
  const double ct = angle.cos, st = angle.sin;
  constexpr double kSin120 = 0.86602540378443865;
  const V3 d0 = ct * n + st * e1;
  const V3 d1 = ct * n + st * (-0.5 * e1 + kSin120 * e2);
  const V3 d2 = ct * n + st * (-0.5 * e1 - kSin120 * e2);
  const SupportVertex w0 = support_difference(a, b, d0), w1 = support_difference(a, b, d1),
                      w2 = support_difference(a, b, d2);
  // The fourth: away from the three points' centroid, so the origin (a
  // little inside their face) lies between (along -n: on half of the
  // paper scene's pairs the origin was outside a side face, 2/3 with this).
  const V3 d3 = -1.0 * (w0.w + w1.w + w2.w);
  return Simplex(w0, w1, w2, support_difference(a, b, d3), d0, d1, d2, d3);
}

}  // namespace

Simplex cone_tetrahedron(const Convex& a, const Convex& b, const V3& n) {
  return cone_tetrahedron(a, b, n, kShapesCone);
}

namespace {

bool closed_form(const Convex& a, const Convex& b, Hit* hit, bool* applies) {
  *applies = true;
  const bool box_a = a.kind == ShapeKind::Cuboid, box_b = b.kind == ShapeKind::Cuboid;
  if (box_a && box_b) return box_box(a, b, hit);
  const bool sph_a = a.is_true_sphere(), sph_b = b.is_true_sphere();
  if (sph_a && sph_b) return sphere_sphere(a, b, hit);
  if (box_a && sph_b) return box_sphere(a, b, hit);
  if (sph_a && box_b) {
    if (!box_sphere(b, a, hit)) return false;
    if (hit) hit->normal = -hit->normal;
    return true;
  }
  *applies = false;
  return false;
}

// What the frame learned: a direction.
void learn(Coherence* learned, const V3& dir, bool contact) {
  learned->dir = dir;
  learned->contact = contact;
}

V3 unit(const V3& v) {
  const double n = norm(v);
  return n > 0 ? v * (1.0 / n) : V3{};
}

// The contact of an intersecting pair from its rounded cores, for pairs
// with an ellipsoid (docs/narrow-phase.md, "Rounded cores"). An ellipsoid
// is its core plus a ball of radius core_radius, so the pair's Minkowski
// difference D is the cores' difference C grown by a ball of radius
// `shell`, the sum of the two: the depth is shell + C's depth when the
// origin lies in C (EPA on the cores), else shell - the origin's distance
// to C (GJK on the cores). Either way the depth reported is D's support
// value along the normal reported, an upper bound as EPA's on the shapes
// is: moving b by it separates them. Near the optimum C is much less round
// than D, so the same tolerance on the depth takes a fraction of the
// iterations. `hint`: a direction from a towards b (last frame's), or null.
// True only with an overlap the cores certify (their tetrahedron encloses
// the origin, or their closest points are less than `shell` apart); false
// when neither shape is an ellipsoid or the cores cannot settle it, and
// then nothing is written: the caller decides on the shapes themselves.
bool rounded_contact(const Convex& a, const Convex& b, const V3* hint, Hit* hit, Coherence* learned,
                     double depth_tolerance) {
  if (core_radius(a) + core_radius(b) == 0) return false;  // no ellipsoid: nothing copied
  // In one order of the two shapes whatever order they come in, the other
  // answered by the mirror image: EPA's steps are not exactly symmetric in
  // floating point, and on a flat optimum the two orders' normals would
  // differ by up to the tolerance's swing.
  if (std::tie(b.kind, b.centre.x, b.centre.y, b.centre.z) < std::tie(a.kind, a.centre.x, a.centre.y, a.centre.z)) {
    const V3 flipped = hint ? -*hint : V3{};
    if (!rounded_contact(b, a, hint ? &flipped : nullptr, hit, learned, depth_tolerance)) return false;
    hit->normal = -hit->normal;
    if (learned) learned->dir = -learned->dir;
    return true;
  }
  const Convex ca = core_of(a), cb = core_of(b);
  const double shell = ca.core_inset + cb.core_inset;
  const auto from_cores = [&](const V3& normal, double depth, const V3& core_a, const V3& core_b) {
    hit->normal = normal;
    hit->depth = depth;
    // The deepest points of the shapes: the cores' grown by their balls.
    hit->point = 0.5 * ((core_a + ca.core_inset * normal) + (core_b - cb.core_inset * normal));
    if (learned) learn(learned, normal, true);
    return true;
  };
  const auto core_epa = [&](const Simplex& s) {
    EpaOptions eo;
    eo.rel_tolerance = depth_tolerance;
    // The tolerance is on the shapes' depth, shell + the cores' depth.
    eo.abs_tolerance += depth_tolerance * shell / pair_scale(ca, cb);
    const EpaResult e = epa(ca, cb, s, eo);
    if (!e.ok || e.separated) return false;
    return from_cores(e.normal, shell + e.depth, e.point_a, e.point_b);
  };
  const auto settle = [&](const GjkResult& g) {
    if (g.intersecting) return core_epa(g.simplex);
    // The origin in the shell: the cores' closest points are g.distance
    // apart, and moving b by shell + h_C(n) along n = -v / |v| separates
    // the shapes (h_C: the cores' support function; one query). GJK's
    // stopping rule puts that within the tolerance of the shapes' depth.
    if (g.distance >= shell || g.distance <= 0) return false;  // touching or degenerate: EPA on the shapes
    const V3 normal = -1.0 / g.distance * g.v;
    const double depth = shell + dot(normal, support_difference(ca, cb, normal).w);
    // The depth is at least shell - g.distance. GJK can stall (no progress
    // on a thin simplex near a cone's apex) with the distance right but -v
    // off the optimum: when the bracket is wider than the tolerance, EPA on
    // the shapes decides.
    const double floor = shell - g.distance;
    if (depth - floor > depth_tolerance * depth + EpaOptions{}.abs_tolerance * pair_scale(a, b)) return false;
    return from_cores(normal, depth, g.closest_a, g.closest_b);
  };
  GjkOptions go;
  go.rel_tolerance = depth_tolerance;
  go.shell = shell;
  if (hint && norm2(*hint) > 0) {
    const Simplex cone = cone_tetrahedron(ca, cb, unit(*hint), kCoresCone);
    if (tetrahedron_encloses_origin(cone)) return core_epa(cone);
    go.initial_simplex = &cone;
    return settle(gjk(ca, cb, go));
  }
  return settle(gjk(ca, cb, go));
}

// EPA from an enclosing simplex (first the rounded cores, unless `cores`
// is false: they were tried); what the frame learns for the pair.
bool epa_contact(const Convex& a, const Convex& b, const Simplex& s, Hit* hit, Coherence* learned,
                 double depth_tolerance, const V3* hint, bool cores) {
  if (cores && rounded_contact(a, b, hint, hit, learned, depth_tolerance)) return true;
  EpaOptions eo;
  eo.rel_tolerance = depth_tolerance;
  const EpaResult e = epa(a, b, s, eo);
  if (e.separated) return false;  // a support value below zero: proved apart
  hit->normal = e.normal;
  hit->depth = e.depth;
  hit->point = 0.5 * (e.point_a + e.point_b);
  if (learned) learn(learned, e.normal, true);
  return true;
}

// `start`: GJK's first search direction (null: the centre line); `warm`:
// last frame's direction, kept for a colliding pair when no normal is
// computed (intersection only).
bool gjk_epa(const Convex& a, const Convex& b, Hit* hit, const V3* start, const V3* warm, Coherence* learned,
             double depth_tolerance, const Simplex* initial = nullptr, bool cores = true) {
  // The verdict never needs the distance of a separated pair: GJK stops at
  // the first separating plane in both modes, so contacts and intersection
  // only give the same verdicts.
  GjkOptions go;
  go.boolean_only = true;
  if (start) go.initial_direction = *start;
  go.initial_simplex = initial;
  GjkResult g = gjk(a, b, go);
  if (!g.intersecting && initial && dot(g.v, support_difference(a, b, -g.v).w) <= 0) {
    // GJK from a warm tetrahedron stopped without a separating plane (no
    // progress on a near-touching pair): its answer there depends on where
    // it started, so the verdict is the cold GJK's (a cylinder-cone pair
    // 2.3e-5 deep at scale 87 stalled 1.3e-6 away from the cone's start).
    go.initial_simplex = nullptr;
    g = gjk(a, b, go);
  }
  if (!g.intersecting) {
    if (learned) learn(learned, unit(-g.v), false);
    return false;
  }
  if (!hit) {
    if (learned) learn(learned, warm ? *warm : V3{}, true);
    return true;
  }
  return epa_contact(a, b, g.simplex, hit, learned, depth_tolerance, warm, cores);
}

// A pair that collided last frame, with contacts: the cone tetrahedron
// around last frame's normal. If its support points enclose the origin
// (GJK's own stopping test), the shapes intersect and EPA starts there,
// without GJK's iterations; otherwise GJK goes on from the cone's closest
// feature (its final tetrahedron from there is a better start for EPA than
// any tetrahedron cached from last frame).
bool warm_contact(const Convex& a, const Convex& b, const V3& normal, Hit* hit, Coherence* learned,
                  double depth_tolerance) {
  // A pair with an ellipsoid: its cores certify the overlap as they give
  // the depth (the shapes' own cone would be four support queries more).
  if (rounded_contact(a, b, &normal, hit, learned, depth_tolerance)) return true;
  const Simplex cone = cone_tetrahedron(a, b, normal);
  if (tetrahedron_encloses_origin(cone)) return epa_contact(a, b, cone, hit, learned, depth_tolerance, &normal, false);
  return gjk_epa(a, b, hit, nullptr, &normal, learned, depth_tolerance, &cone, false);
}

}  // namespace

bool intersect(const Convex& a, const Convex& b, Hit* hit, NarrowMethod method) {
  return intersect(a, b, hit, method, nullptr, nullptr);
}

bool intersect(const Convex& a, const Convex& b, Hit* hit, NarrowMethod method, const Coherence* warm,
               Coherence* learned, double depth_tolerance) {
  if (learned) learn(learned, {}, false);
  // Bounding spheres apart: no further work (most broad-phase false positives).
  const double reach = a.radius + b.radius;
  if (norm2(b.centre - a.centre) > reach * reach) return false;
  if (method == NarrowMethod::Auto || method == NarrowMethod::GjkEpa) {
    bool applies = false;
    if (method == NarrowMethod::Auto) {
      const bool r = closed_form(a, b, hit, &applies);
      if (applies) return r;
    }
    // A pair that collided last frame almost always still does: straight
    // to GJK. GJK starts from the centre line, not from the cached normal:
    // its final tetrahedron is then a better start for EPA (paper scene,
    // n = 20,000: 14.1 EPA iterations per pair instead of 14.8, 5-9 % less
    // CPU in all).
    if (warm && warm->contact) {
      if (hit && norm2(warm->dir) > 0) return warm_contact(a, b, warm->dir, hit, learned, depth_tolerance);
      return gjk_epa(a, b, hit, nullptr, &warm->dir, learned, depth_tolerance);
    }
    // Last frame's axis still separates: one support query (h_D(u) < 0).
    if (warm) {
      const SupportVertex w = support_difference(a, b, warm->dir);
      if (dot(warm->dir, w.w) < 0) {
        if (learned) learn(learned, warm->dir, false);
        return false;
      }
    }
    // Oriented bounding boxes apart (15 axes).
    V3 axis;
    if (obb_disjoint(a, b, &axis)) {
      if (learned) learn(learned, axis, false);
      return false;
    }
    return gjk_epa(a, b, hit, warm ? &warm->dir : nullptr, warm ? &warm->dir : nullptr, learned, depth_tolerance);
  }
  switch (method) {
    case NarrowMethod::Auto:
    case NarrowMethod::GjkEpa: return false;  // handled above
    case NarrowMethod::LibccdMpr: return libccd_intersect(a, b, hit, CcdAlgorithm::Mpr);
    case NarrowMethod::LibccdGjkEpa: return libccd_intersect(a, b, hit, CcdAlgorithm::GjkEpa);
  }
  return false;
}

}  // namespace narrow

bool intersect(const Shape& a, const Shape& b, Contact* contact, NarrowMethod method) {
  const narrow::Convex ca = narrow::make_convex(a), cb = narrow::make_convex(b);
  if (!contact) return narrow::intersect(ca, cb, nullptr, method);
  narrow::Hit hit;
  if (!narrow::intersect(ca, cb, &hit, method)) return false;
  contact->normal = narrow::to_vec3(hit.normal);
  contact->depth = hit.depth;
  contact->point = narrow::to_vec3(hit.point);
  return true;
}

double signed_distance(const Shape& a, const Shape& b) {
  const narrow::Convex ca = narrow::make_convex(a), cb = narrow::make_convex(b);
  const narrow::GjkResult g = narrow::gjk(ca, cb);
  if (!g.intersecting) return g.distance;
  return -narrow::epa(ca, cb, g.simplex).depth;
}

}  // namespace hbp
