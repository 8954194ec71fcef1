// SPDX-License-Identifier: MIT
#include "hbp/narrow/gjk.hpp"

#include <algorithm>
#include <cmath>
#include <initializer_list>
#include <utility>

namespace hbp::narrow {
namespace {

void keep1(Simplex& s, int i) {
  s.v[0] = s.v[i];
  s.dir[0] = s.dir[i];
  s.lambda[0] = 1;
  s.n = 1;
}

void keep2(Simplex& s, int i, int j, double li, double lj) {
  const SupportVertex vi = s.v[i], vj = s.v[j];
  const V3 di = s.dir[i], dj = s.dir[j];
  s.v[0] = vi;
  s.v[1] = vj;
  s.dir[0] = di;
  s.dir[1] = dj;
  s.lambda[0] = li;
  s.lambda[1] = lj;
  s.n = 2;
}

void keep3(Simplex& s, int i, int j, int k, double li, double lj, double lk) {
  const SupportVertex vi = s.v[i], vj = s.v[j], vk = s.v[k];
  const V3 di = s.dir[i], dj = s.dir[j], dk = s.dir[k];
  s.v[0] = vi;
  s.v[1] = vj;
  s.v[2] = vk;
  s.dir[0] = di;
  s.dir[1] = dj;
  s.dir[2] = dk;
  s.lambda[0] = li;
  s.lambda[1] = lj;
  s.lambda[2] = lk;
  s.n = 3;
}

V3 combine(const Simplex& s) {
  V3 p;
  for (int i = 0; i < s.n; ++i) p = p + s.lambda[i] * s.v[i].w;
  return p;
}

// The closest feature of a segment or triangle of s to the origin: which
// vertices it keeps, with their barycentric weights. Computed without
// touching s, so the faces of a tetrahedron can be compared without copying
// the simplex (about 500 bytes) for each.
struct Feature {
  int n = 0;
  int idx[3];
  double lambda[3];
};

Feature feature1(int i) {
  Feature f;
  f.n = 1;
  f.idx[0] = i;
  f.lambda[0] = 1;
  return f;
}

Feature feature2(int i, int j, double li, double lj) {
  Feature f;
  f.n = 2;
  f.idx[0] = i;
  f.idx[1] = j;
  f.lambda[0] = li;
  f.lambda[1] = lj;
  return f;
}

V3 feature_point(const Simplex& s, const Feature& f) {
  V3 p;
  for (int i = 0; i < f.n; ++i) p = p + f.lambda[i] * s.v[f.idx[i]].w;
  return p;
}

void apply(Simplex& s, const Feature& f) {
  switch (f.n) {
    case 1: return keep1(s, f.idx[0]);
    case 2: return keep2(s, f.idx[0], f.idx[1], f.lambda[0], f.lambda[1]);
    default: return keep3(s, f.idx[0], f.idx[1], f.idx[2], f.lambda[0], f.lambda[1], f.lambda[2]);
  }
}

// Closest point of segment (s.v[i], s.v[j]) to the origin.
Feature segment_feature(const Simplex& s, int i, int j) {
  const V3 a = s.v[i].w, b = s.v[j].w;
  const V3 ab = b - a;
  const double len2 = norm2(ab);
  const double t = len2 > 0 ? -dot(a, ab) / len2 : 0;
  if (t <= 0) return feature1(i);
  if (t >= 1) return feature1(j);
  return feature2(i, j, 1 - t, t);
}

void closest_segment(Simplex& s, int i, int j) { apply(s, segment_feature(s, i, j)); }

// Closest point of triangle (s.v[i], s.v[j], s.v[k]) to the origin, by the
// Voronoi regions of its vertices, edges and face.
Feature triangle_feature(const Simplex& s, int i, int j, int k) {
  const V3 a = s.v[i].w, b = s.v[j].w, c = s.v[k].w;
  const V3 ab = b - a, ac = c - a;
  const double d1 = -dot(ab, a), d2 = -dot(ac, a);
  if (d1 <= 0 && d2 <= 0) return feature1(i);
  const double d3 = -dot(ab, b), d4 = -dot(ac, b);
  if (d3 >= 0 && d4 <= d3) return feature1(j);
  const double vc = d1 * d4 - d3 * d2;
  if (vc <= 0 && d1 >= 0 && d3 <= 0) {
    const double t = d1 / (d1 - d3);
    return feature2(i, j, 1 - t, t);
  }
  const double d5 = -dot(ab, c), d6 = -dot(ac, c);
  if (d6 >= 0 && d5 <= d6) return feature1(k);
  const double vb = d5 * d2 - d1 * d6;
  if (vb <= 0 && d2 >= 0 && d6 <= 0) {
    const double t = d2 / (d2 - d6);
    return feature2(i, k, 1 - t, t);
  }
  const double va = d3 * d6 - d5 * d4;
  if (va <= 0 && (d4 - d3) >= 0 && (d5 - d6) >= 0) {
    const double t = (d4 - d3) / ((d4 - d3) + (d5 - d6));
    return feature2(j, k, 1 - t, t);
  }
  const double sum = va + vb + vc;
  if (!(sum > 0)) {  // degenerate (collinear) triangle: best of its edges
    Feature best = segment_feature(s, i, j);
    double best_d = norm2(feature_point(s, best));
    for (const auto& e : {std::pair{j, k}, std::pair{i, k}}) {
      const Feature t = segment_feature(s, e.first, e.second);
      const double d = norm2(feature_point(s, t));
      if (d < best_d) {
        best = t;
        best_d = d;
      }
    }
    return best;
  }
  const double v = vb / sum, w = vc / sum;
  Feature f;
  f.n = 3;
  f.idx[0] = i;
  f.idx[1] = j;
  f.idx[2] = k;
  f.lambda[0] = 1 - v - w;
  f.lambda[1] = v;
  f.lambda[2] = w;
  return f;
}

void closest_triangle(Simplex& s, int i, int j, int k) { apply(s, triangle_feature(s, i, j, k)); }

constexpr int kTetFaces[4][4] = {{0, 1, 2, 3}, {0, 2, 3, 1}, {0, 3, 1, 2}, {1, 3, 2, 0}};

// A sliver (volume tiny against its edges, e.g. three nearly equal support
// points of a curved surface and one far vertex) has face planes whose
// sides are rounding noise: it must never certify that it encloses the
// origin. It is treated as flat.
bool is_sliver(const Simplex& s) {
  const V3 e1 = s.v[1].w - s.v[0].w, e2 = s.v[2].w - s.v[0].w, e3 = s.v[3].w - s.v[0].w;
  // |det| > 1e-12 x the product of the edge lengths, squared (no square root).
  const double vol6 = det3(e1, e2, e3);
  return !(vol6 * vol6 > 1e-24 * (norm2(e1) * norm2(e2) * norm2(e3)));
}

// Face f of the tetrahedron: the origin strictly on the other side of its
// plane than the fourth vertex (or the plane through the fourth vertex):
// the closest point may lie on this face.
bool origin_beyond_face(const Simplex& s, const int f[4]) {
  const V3 a = s.v[f[0]].w, b = s.v[f[1]].w, c = s.v[f[2]].w, d = s.v[f[3]].w;
  const V3 n = cross(b - a, c - a);
  const double side_origin = -dot(a, n);
  const double side_opposite = dot(d - a, n);
  return side_opposite == 0 || side_origin * side_opposite < 0;
}

// Tetrahedron: true if the origin is inside (s unchanged, lambda set);
// otherwise reduces s to the closest face/edge/vertex. *sliver: the
// tetrahedron was too flat to decide and was treated as flat.
bool closest_tetrahedron(Simplex& s, bool* sliver_out) {
  const bool sliver = is_sliver(s);
  *sliver_out = sliver;
  bool outside_any = false;
  Feature best;
  double best_d = INFINITY;
  for (const auto& f : kTetFaces) {
    if (sliver || origin_beyond_face(s, f)) {
      outside_any = true;
      const Feature t = triangle_feature(s, f[0], f[1], f[2]);
      const double dist = norm2(feature_point(s, t));
      if (dist < best_d) {
        best_d = dist;
        best = t;
      }
    }
  }
  if (!outside_any) {
    // Barycentric weights from signed volumes.
    const V3 a = s.v[0].w, b = s.v[1].w, c = s.v[2].w, d = s.v[3].w;
    const double vol = det3(b - a, c - a, d - a);
    const V3 o{};
    s.lambda[0] = det3(b - o, c - o, d - o) / vol;
    s.lambda[1] = det3(o - a, c - a, d - a) / vol;
    s.lambda[2] = det3(b - a, o - a, d - a) / vol;
    s.lambda[3] = det3(b - a, c - a, o - a) / vol;
    return true;
  }
  apply(s, best);
  return false;
}

}  // namespace

bool tetrahedron_encloses_origin(const Simplex& s) {
  if (s.n != 4 || is_sliver(s)) return false;
  for (const auto& f : kTetFaces)
    if (origin_beyond_face(s, f)) return false;
  return true;
}

GjkResult gjk(const Convex& a, const Convex& b, const GjkOptions& options) {
  GjkResult r;
  Simplex& s = r.simplex;
  const double scale = pair_scale(a, b);
  const double touch2 = (1e-12 * scale) * (1e-12 * scale);
  const double eps = options.rel_tolerance;
  // Shapes closer than this (relative to their size) may be called touching
  // when the simplex has gone flat: far inside the agreement band with
  // Bullet (1e-4 m + 2e-6 x scale, docs/narrow-phase.md).
  const double sliver_touch2 = (1e-10 * scale) * (1e-10 * scale);

  // v: a point of D (both centres are interior), or minus the cached
  // direction: only its direction matters for the first support query.
  V3 v = a.centre - b.centre;
  if (norm2(options.initial_direction) > 0) v = -options.initial_direction;
  if (norm2(v) == 0) v = {scale, 0, 0};
  double prev_vv = INFINITY;
  // Distance mode: the closest points of A and B of the last simplex that
  // came closer to the origin (a no-progress exit reports these, without
  // keeping a 424-byte copy of that simplex on every iteration).
  V3 pa, pb;
  const auto closest_points = [&] {
    pa = pb = V3{};
    for (int i = 0; i < s.n; ++i) {
      pa = pa + s.lambda[i] * s.v[i].a;
      pb = pb + s.lambda[i] * s.v[i].b;
    }
  };
  if (options.initial_simplex && options.initial_simplex->n == 4) {
    // A tetrahedron from last frame's knowledge: reduced to its closest
    // feature as if GJK had just built it.
    s = *options.initial_simplex;
    bool sliver = false;
    const bool inside = closest_tetrahedron(s, &sliver);
    const V3 c = combine(s);
    if (inside || (sliver && norm2(c) <= sliver_touch2) || norm2(c) <= touch2) {
      r.intersecting = true;
      r.distance = 0;
      return r;
    }
    v = c;
    prev_vv = norm2(c);
    if (!options.boolean_only) closest_points();
  }
  for (int it = 0; it < options.max_iterations; ++it) {
    r.iterations = it + 1;
    const SupportVertex w = support_difference(a, b, -v);
    const double vv = norm2(v);
    const double vw = dot(v, w.w);
    if (vw > 0 && options.boolean_only) {
      // Separating plane found: D lies entirely on the far side of it.
      r.intersecting = false;
      r.distance = vw / std::sqrt(vv);
      r.v = v;
      return r;
    }
    if (s.n > 0) {
      bool duplicate = false;
      for (int i = 0; i < s.n; ++i) duplicate |= (s.v[i].w.x == w.w.x && s.v[i].w.y == w.w.y && s.v[i].w.z == w.w.z);
      // vv - vw = |v| (|v| - lower bound); in shell mode the room is
      // |v| (shell - |v|), floored so that a touching pair still stops.
      const double room = options.shell > 0 ? std::max(options.shell * std::sqrt(vv) - vv, 1e-6 * vv) : vv;
      if (duplicate || vv - vw <= eps * room) break;  // converged: separated
    }
    const V3 v_before = v;
    s.dir[s.n] = -v;
    s.v[s.n++] = w;
    bool inside = false, sliver = false;
    switch (s.n) {
      case 1: s.lambda[0] = 1; break;
      case 2: closest_segment(s, 0, 1); break;
      case 3: closest_triangle(s, 0, 1, 2); break;
      default: inside = closest_tetrahedron(s, &sliver); break;
    }
    if (sliver && norm2(combine(s)) <= sliver_touch2) {
      // A flat simplex within the touching tolerance of the origin: touching
      // (EPA certifies or refutes it with a support value).
      r.intersecting = true;
      r.distance = 0;
      return r;
    }
    if (inside) {
      r.intersecting = true;
      r.distance = 0;
      return r;
    }
    v = combine(s);
    const double nv = norm2(v);
    if (nv <= touch2) {  // origin on the simplex: touching counts as contact
      r.intersecting = true;
      r.distance = 0;
      return r;
    }
    if (nv >= prev_vv) {  // no progress: numerically converged; keep the last good v and closest points
      v = v_before;
      break;
    }
    prev_vv = nv;
    if (!options.boolean_only) closest_points();
  }
  // A boolean query that ends here found no separating plane (a touching
  // pair): its closest points are the final simplex's.
  if (options.boolean_only) closest_points();
  r.intersecting = false;
  r.distance = norm(v);
  r.v = v;
  r.closest_a = pa;
  r.closest_b = pb;
  return r;
}

}  // namespace hbp::narrow
