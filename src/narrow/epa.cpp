#include "hbp/narrow/epa.hpp"

#include <cmath>
#include <type_traits>
#include <utility>

namespace hbp::narrow {
namespace {

constexpr int kMaxVertices = kEpaMaxVertices;
constexpr int kMaxFaces = 2 * kMaxVertices + 32;

// Triangle of the polytope. Edge e runs v[e] -> v[(e + 1) % 3]; adj[e] is the
// face across it and adj_edge[e] that face's index for the same edge.
struct Face {
  V3 n;
  double d;  // distance of the face plane from the origin
  int v[3];
  int adj[3];
  int adj_edge[3];
  unsigned pass;
};

// Fixed-size storage left uninitialised: V3's default member initialisers
// would otherwise zero about 50 kB of polytope on every EPA call, most of
// it never used. Elements are written before they are read.
template <class T, int N>
struct Uninitialised {
  static_assert(std::is_trivially_destructible_v<T> && std::is_trivially_copyable_v<T>);
  union {
    T v[N];
  };
  Uninitialised() {}
  T& operator[](int i) { return v[i]; }
  const T& operator[](int i) const { return v[i]; }
};

constexpr int kNext[3] = {1, 2, 0};  // (e + 1) % 3 without a division

struct Horizon {
  int first = -1, last = -1, count = 0;
  bool broken = false;
};

class Polytope {
 public:
  explicit Polytope(double scale)
      : area_eps_(1e-14 * scale * scale), plane_eps_(1e-13 * scale) {}

  int add_vertex(const SupportVertex& s) {
    verts_[nv_] = s;
    return nv_++;
  }
  int vertex_count() const { return nv_; }
  const SupportVertex& vertex(int i) const { return verts_[i]; }
  Face& face(int f) { return faces_[f]; }

  // New face (a, b, c), counter-clockwise seen from outside. -1 if out of
  // capacity or degenerate (no reliable normal).
  int new_face(int a, int b, int c) {
    int f;
    if (nfree_ > 0) {
      f = free_[--nfree_];
    } else if (nused_ < kMaxFaces) {
      f = nused_++;
    } else {
      return -1;
    }
    Face& F = faces_[f];
    const V3 n = cross(verts_[b].w - verts_[a].w, verts_[c].w - verts_[a].w);
    const double len = norm(n);
    if (!(len > area_eps_)) {
      dist_[f] = INFINITY;
      free_[nfree_++] = f;
      return -1;
    }
    F.n = n * (1.0 / len);
    F.d = dot(F.n, verts_[a].w + verts_[b].w + verts_[c].w) * (1.0 / 3.0);  // the mean over the 3 vertices
    F.v[0] = a;
    F.v[1] = b;
    F.v[2] = c;
    F.adj[0] = F.adj[1] = F.adj[2] = -1;
    F.adj_edge[0] = F.adj_edge[1] = F.adj_edge[2] = 0;
    F.pass = 0;
    dist_[f] = F.d;
    return f;
  }

  void release(int f) {
    dist_[f] = INFINITY;
    free_[nfree_++] = f;
  }

  void link(int f, int e, int g, int h) {
    faces_[f].adj[e] = g;
    faces_[f].adj_edge[e] = h;
    faces_[g].adj[h] = f;
    faces_[g].adj_edge[h] = e;
  }

  // A scan of the dense distance array (dead faces hold +inf): cheaper than
  // walking the faces themselves, and the polytope stays small (tens of faces).
  int closest_face() const {
    int best = -1;
    double best_d = INFINITY;
    for (int f = 0; f < nused_; ++f) {
      const double d = dist_[f];
      if (d < best_d) {
        best_d = d;
        best = f;
      }
    }
    return best;
  }

  // Depth-first walk over the faces visible from vertex w, starting across
  // edge e of face f. Visible faces are queued for removal; for each horizon
  // edge a new face (edge, w) is made and stitched to its predecessor.
  bool silhouette(unsigned pass, int w, int f, int e, Horizon& h) {
    Face& F = faces_[f];
    if (F.pass == pass) return true;  // visible face reached a second time
    const int e1 = kNext[e];
    if (dot(F.n, verts_[w].w) - F.d < -plane_eps_) {
      const int nf = new_face(F.v[e1], F.v[e], w);
      if (nf < 0) return false;
      link(nf, 0, f, e);
      if (h.last >= 0) {
        if (faces_[h.last].v[1] != faces_[nf].v[0]) h.broken = true;
        link(h.last, 1, nf, 2);
      } else {
        h.first = nf;
      }
      h.last = nf;
      ++h.count;
      return true;
    }
    const int e2 = kNext[e1];
    F.pass = pass;
    if (nremoved_ >= kMaxFaces) return false;
    removed_[nremoved_++] = f;
    return silhouette(pass, w, F.adj[e1], F.adj_edge[e1], h) &&
           silhouette(pass, w, F.adj[e2], F.adj_edge[e2], h);
  }

  void begin_pass() { nremoved_ = 0; }
  void release_removed() {
    for (int i = 0; i < nremoved_; ++i) release(removed_[i]);
  }


 private:
  double area_eps_, plane_eps_;
  Uninitialised<SupportVertex, kMaxVertices> verts_;
  int nv_ = 0;
  Uninitialised<Face, kMaxFaces> faces_;
  Uninitialised<double, kMaxFaces> dist_;  // faces_[f].d, or +inf once released
  int free_[kMaxFaces];
  int removed_[kMaxFaces];
  int nfree_ = 0, nused_ = 0, nremoved_ = 0;
};

// Grows a GJK simplex touching or enclosing the origin into a tetrahedron of
// non-zero volume by adding support points in directions that leave its span.
bool enclose_origin(const Convex& a, const Convex& b, Simplex& s, double scale) {
  static const V3 kAxes[3] = {{1, 0, 0}, {0, 1, 0}, {0, 0, 1}};
  auto try_direction = [&](const V3& d) {
    s.v[s.n++] = support_difference(a, b, d);
    if (enclose_origin(a, b, s, scale)) return true;
    --s.n;
    return false;
  };
  switch (s.n) {
    case 1:
      for (const V3& axis : kAxes) {
        if (try_direction(axis) || try_direction(-axis)) return true;
      }
      return false;
    case 2: {
      const V3 d = s.v[1].w - s.v[0].w;
      for (const V3& axis : kAxes) {
        const V3 p = cross(d, axis);
        if (norm2(p) > 0 && (try_direction(p) || try_direction(-p))) return true;
      }
      return false;
    }
    case 3: {
      const V3 n = cross(s.v[1].w - s.v[0].w, s.v[2].w - s.v[0].w);
      return norm2(n) > 0 && (try_direction(n) || try_direction(-n));
    }
    case 4: {
      const double vol = det3(s.v[1].w - s.v[0].w, s.v[2].w - s.v[0].w, s.v[3].w - s.v[0].w);
      return std::fabs(vol) > 1e-15 * scale * scale * scale;
    }
    default: return false;
  }
}

void fill_result(const Polytope& p, const Face& f, EpaResult& r) {
  r.ok = true;
  r.depth = f.d > 0 ? f.d : 0;
  r.normal = f.n;
  // Barycentric coordinates of the origin's projection on the face.
  const V3 a = p.vertex(f.v[0]).w, b = p.vertex(f.v[1]).w, c = p.vertex(f.v[2]).w;
  const V3 q = f.n * f.d;
  const V3 v0 = b - a, v1 = c - a, v2 = q - a;
  const double d00 = dot(v0, v0), d01 = dot(v0, v1), d11 = dot(v1, v1);
  const double d20 = dot(v2, v0), d21 = dot(v2, v1);
  const double den = d00 * d11 - d01 * d01;
  double l1 = den != 0 ? (d11 * d20 - d01 * d21) / den : 1.0 / 3;
  double l2 = den != 0 ? (d00 * d21 - d01 * d20) / den : 1.0 / 3;
  double l0 = 1 - l1 - l2;
  r.point_a = l0 * p.vertex(f.v[0]).a + l1 * p.vertex(f.v[1]).a + l2 * p.vertex(f.v[2]).a;
  r.point_b = l0 * p.vertex(f.v[0]).b + l1 * p.vertex(f.v[1]).b + l2 * p.vertex(f.v[2]).b;
}

// Lowers the upper bound f = h_D(u) by projected gradient descent on the unit
// sphere (the gradient of the support function h_D at u is the support point
// s_D(u)); with backtracking every accepted step is a valid, smaller bound.
// Used where EPA stops early: deep, nearly concentric curved shapes, whose
// Minkowski difference is almost a sphere about the origin.
void refine_upper_bound(const Convex& a, const Convex& b, double scale, double& f, V3& u, V3& pa, V3& pb) {
  V3 s = pa - pb;
  double step = 1.0 / std::fmax(norm(s), 1e-300);
  for (int k = 0; k < 40; ++k) {
    const V3 g = s - dot(s, u) * u;  // tangential part of the gradient
    if (norm(g) <= 1e-12 * scale) return;
    bool improved = false;
    for (int t = 0; t < 10 && !improved; ++t) {
      V3 c = u - step * g;
      c = c * (1.0 / norm(c));
      const SupportVertex w = support_difference(a, b, c);
      const double fc = dot(c, w.w);
      if (fc < f) {
        f = fc;
        u = c;
        pa = w.a;
        pb = w.b;
        s = w.w;
        step *= 1.5;
        improved = true;
      } else {
        step *= 0.5;
      }
    }
    if (!improved) return;
  }
}

}  // namespace

EpaResult epa(const Convex& a, const Convex& b, const Simplex& simplex, const EpaOptions& options) {
  EpaResult r;
  const double scale = pair_scale(a, b);
  {
    const V3 d = b.centre - a.centre;
    const double len = norm(d);
    r.normal = len > 0 ? d * (1.0 / len) : V3{0, 0, 1};
  }
  // Without a polytope, the support function along the centre line, lowered
  // by descent, is the answer: h_D(u) < 0 proves the shapes apart (GJK's
  // verdict was wrong), else h_D(u) is a translation that separates them.
  // Never a silent depth-0 contact.
  auto without_polytope = [&]() {
    V3 u = r.normal;
    SupportVertex w = support_difference(a, b, u);
    double f = dot(u, w.w);
    V3 pa = w.a, pb = w.b;
    refine_upper_bound(a, b, scale, f, u, pa, pb);
    r.ok = false;
    r.separated = f < 0;
    r.depth = f > 0 ? f : 0;
    r.normal = u;
    r.point_a = pa;
    r.point_b = pb;
    return r;
  };
  Simplex s = simplex;
  if (s.n < 1 || !enclose_origin(a, b, s, scale)) return without_polytope();

  Polytope p(scale);
  int vi[4];
  for (int i = 0; i < 4; ++i) vi[i] = p.add_vertex(s.v[i]);
  // Faces of the tetrahedron (i, j, k) with opposite vertex l, wound so that
  // their normals point away from l.
  static constexpr int kTet[4][4] = {{0, 1, 2, 3}, {0, 3, 1, 2}, {0, 2, 3, 1}, {1, 3, 2, 0}};
  int tf[4];
  for (int t = 0; t < 4; ++t) {
    int i = vi[kTet[t][0]], j = vi[kTet[t][1]], k = vi[kTet[t][2]];
    const V3 wi = p.vertex(i).w;
    if (dot(cross(p.vertex(j).w - wi, p.vertex(k).w - wi), p.vertex(vi[kTet[t][3]]).w - wi) > 0) std::swap(j, k);
    tf[t] = p.new_face(i, j, k);
    if (tf[t] < 0) return without_polytope();
  }
  for (int f = 0; f < 4; ++f) {
    for (int e = 0; e < 3; ++e) {
      const Face& F = p.face(tf[f]);
      const int from = F.v[e], to = F.v[(e + 1) % 3];
      for (int g = 0; g < 4; ++g) {
        if (g == f) continue;
        const Face& G = p.face(tf[g]);
        for (int h = 0; h < 3; ++h) {
          if (G.v[h] == to && G.v[(h + 1) % 3] == from) p.link(tf[f], e, tf[g], h);
        }
      }
    }
  }

  // Every support query along a unit normal n gives an upper bound h_D(n) of
  // the depth (moving b by n * h_D(n) separates the shapes); the closest face
  // gives a lower bound. If EPA stops short of its tolerance (capacity, or a
  // degenerate update) the best upper bound is reported: a translation that
  // does separate, not one that falls short.
  double upper = INFINITY;
  V3 upper_normal, upper_a, upper_b;
  unsigned pass = 0;
  double last_d = 0;  // the closest face's distance: a lower bound of the depth
  for (int it = 0;; ++it) {
    r.iterations = it;
    const int best = p.closest_face();
    if (best < 0) break;
    Face& B = p.face(best);
    last_d = B.d;
    const SupportVertex w = support_difference(a, b, B.n);
    const double hd = dot(B.n, w.w);
    if (hd < upper) {
      upper = hd;
      upper_normal = B.n;
      upper_a = w.a;
      upper_b = w.b;
    }
    const double gap = hd - B.d;
    if (gap <= options.rel_tolerance * std::fabs(B.d) + options.abs_tolerance * scale) {
      // Report the support value along the face normal (the upper end of the
      // bracket): moving b by it separates the shapes, never falls short.
      fill_result(p, B, r);
      r.converged = true;
      r.lower_bound = B.d;
      r.depth = hd > 0 ? hd : 0;
      break;
    }
    if (p.vertex_count() >= kMaxVertices) break;
    const int wi = p.add_vertex(w);
    B.pass = ++pass;
    p.begin_pass();
    Horizon h;
    bool ok = true;
    for (int e = 0; e < 3 && ok; ++e) ok = p.silhouette(pass, wi, B.adj[e], B.adj_edge[e], h);
    if (!ok || h.broken || h.count < 3 || p.face(h.last).v[1] != p.face(h.first).v[0]) break;
    p.link(h.last, 1, h.first, 2);
    p.release_removed();
    p.release(best);
  }
  if (!r.converged && upper == INFINITY) return without_polytope();
  r.ok = true;
  if (!r.converged) r.lower_bound = last_d > 0 ? last_d : 0;
  // A support value below zero is a separating plane: GJK's simplex did not
  // really enclose the origin.
  r.separated = upper < 0;
  if (!r.converged && upper < INFINITY) {
    refine_upper_bound(a, b, scale, upper, upper_normal, upper_a, upper_b);
    r.depth = upper > 0 ? upper : 0;
    r.normal = upper_normal;
    r.point_a = upper_a;
    r.point_b = upper_b;
  }
  return r;
}

}  // namespace hbp::narrow
