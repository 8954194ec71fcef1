// SPDX-License-Identifier: MIT
#pragma once
// EPA's polytope: a closed triangle mesh inscribed in the Minkowski
// difference D = A - B, enclosing the origin, in fixed-size arrays (no
// allocation, nothing zeroed up front).
//
// Laid out for the two loops that run every iteration: the closest-face scan
// reads only the dense distance array; the horizon walk reads a face's plane
// and its topology (vertex and neighbour indices in 12 bytes) and the new
// vertex. The support points of A behind each vertex are kept apart (B's is
// a - w): they are read only once, for the contact point of the final face.
//
// Coordinates are stored one array per component (structure of arrays).
// Not for streaming: a vertex or face plane is read back within tens of
// cycles of being written, and the compiler loads a V3 kept as a struct with
// one 16-byte load, which the processor cannot forward from the two 8-byte
// stores that wrote it; each such load then waits for the stores to retire.
// That made EPA 1.7x slower in time at the same instruction count (AMD EPYC).
#include <cmath>
#include <cstdint>
#include <type_traits>

#include "hbp/narrow/epa.hpp"

namespace hbp::narrow::epa_detail {

inline constexpr int kMaxVertices = kEpaMaxVertices;
inline constexpr int kMaxFaces = 2 * kMaxVertices + 32;
// A half-edge is named by face * 4 + edge (edge in 0..2).
static_assert(kMaxVertices <= 256, "vertex indices are 8 bits");
static_assert(kMaxFaces * 4 <= 65536, "half-edge references are 16 bits");

struct FacePlane {
  V3 n;      // unit outward normal
  double d;  // distance of the plane from the origin (the closest face's is a lower bound of the depth)
};

// Triangle v[0] v[1] v[2], counter-clockwise seen from outside. Edge e runs
// v[e] -> v[e + 1 mod 3]; adj[e] is the half-edge across it (its face * 4 +
// its edge index).
struct FaceTopology {
  std::uint8_t v[3];
  std::uint8_t unused;
  std::uint16_t adj[3];
  std::uint16_t pass;  // the expansion that last found the face visible
};
static_assert(sizeof(FaceTopology) == 12);

// Fixed-size storage left uninitialised (zeroing ~40 kB per EPA call would
// cost more than most calls' work). Elements are written before they are read.
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

inline constexpr int kNext[3] = {1, 2, 0};  // (e + 1) % 3 without a division

class Polytope {
 public:
  explicit Polytope(double scale) : area_eps2_(1e-28 * scale * scale * scale * scale), plane_eps_(1e-13 * scale) { free_[0] = 0; }

  int vertex_count() const { return nv_; }
  V3 w(int i) const { return {wx_[i], wy_[i], wz_[i]}; }
  V3 point_a(int i) const { return a_[i]; }
  V3 point_b(int i) const { return a_[i] - w(i); }
  FacePlane plane(int f) const { return {{nx_[f], ny_[f], nz_[f]}, dist_[f]}; }
  const FaceTopology& topology(int f) const { return topo_[f]; }

  int add_vertex(const SupportVertex& s) {
    wx_[nv_] = s.w.x;
    wy_[nv_] = s.w.y;
    wz_[nv_] = s.w.z;
    a_[nv_] = s.a;
    return nv_++;
  }

  // The tetrahedron of vertices 0..3 (added first; non-zero volume). False if
  // a face is degenerate.
  bool make_tetrahedron() {
    // Faces (0 1 2), (0 3 1), (0 2 3), (1 3 2) point away from the opposite
    // vertex when det(w1 - w0, w2 - w0, w3 - w0) < 0: swap 1 and 2 otherwise.
    std::uint8_t i0 = 0, i1 = 1, i2 = 2, i3 = 3;
    if (det3(w(1) - w(0), w(2) - w(0), w(3) - w(0)) > 0) {
      i1 = 2;
      i2 = 1;
    }
    if (new_face(i0, i1, i2) != 0 || new_face(i0, i3, i1) != 1 || new_face(i0, i2, i3) != 2 ||
        new_face(i1, i3, i2) != 3)
      return false;
    // Twins: (i0 i1) 0.0-1.2, (i1 i2) 0.1-3.2, (i2 i0) 0.2-2.0, (i0 i3)
    // 1.0-2.2, (i3 i1) 1.1-3.0, (i2 i3) 2.1-3.1.
    link(0, 0, 1, 2);
    link(0, 1, 3, 2);
    link(0, 2, 2, 0);
    link(1, 0, 2, 2);
    link(1, 1, 3, 0);
    link(2, 1, 3, 1);
    return true;
  }

  // The live face closest to the origin (released faces hold +inf in the
  // dense distance array), or -1 if none.
  int closest_face() const {
    int best = -1;
    double best_d = INFINITY;
    for (int f = 0; f < nused_; ++f) {
      if (dist_[f] < best_d) {
        best_d = dist_[f];
        best = f;
      }
    }
    return best;
  }

  // Adds vertex wi, outside the polytope and seen by face `from`: removes
  // every face that sees it (a walk from `from` across edges, stopping at
  // faces that do not) and closes the hole with a fan of faces to wi along
  // the horizon. False if the update degenerates (a face too small for a
  // reliable normal, a horizon that does not close): the polytope is then
  // unusable.
  bool expand(int from, int wi) {
    const double x = wx_[wi], y = wy_[wi], z = wz_[wi];
    const std::uint16_t pass = ++pass_;
    topo_[from].pass = pass;
    nremoved_ = 0;
    removed_[nremoved_++] = static_cast<std::uint16_t>(from);
    // Depth-first, iteratively: half-edges still to cross, the next on top.
    std::uint16_t stack[2 * kMaxFaces + 4];
    int sp = 0;
    stack[sp++] = topo_[from].adj[2];
    stack[sp++] = topo_[from].adj[1];
    stack[sp++] = topo_[from].adj[0];
    // The fan of new faces is stitched as it is made, each to the one
    // before; the first is stitched to a scratch face (slot kMaxFaces), so
    // no branch tells the first from the others.
    constexpr int kScratch = kMaxFaces;
    int last = kScratch, count = 0;
    bool broken = false;
    while (sp > 0) {
      const int ref = stack[--sp];
      const int f = ref >> 2, e = ref & 3;
      FaceTopology& F = topo_[f];
      if (F.pass == pass) continue;  // a visible face reached a second time
      const int e1 = kNext[e];
      if (nx_[f] * x + ny_[f] * y + nz_[f] * z - dist_[f] < -plane_eps_) {
        // f does not see w: its edge e is on the horizon.
        const int nf = new_face(F.v[e1], F.v[e], wi, V3{x, y, z});
        if (nf < 0) return false;
        link(nf, 0, f, e);
        broken |= (last != kScratch) & (topo_[last].v[1] != topo_[nf].v[0]);
        link(last, 1, nf, 2);
        last = nf;
        ++count;
        continue;
      }
      F.pass = pass;
      removed_[nremoved_++] = static_cast<std::uint16_t>(f);
      stack[sp++] = F.adj[kNext[e1]];
      stack[sp++] = F.adj[e1];
    }
    if (broken || count < 3) return false;
    const int first = topo_[kScratch].adj[1] >> 2;
    if (topo_[last].v[1] != topo_[first].v[0]) return false;
    link(last, 1, first, 2);
    for (int i = 0; i < nremoved_; ++i) release(removed_[i]);
    return true;
  }

 private:
  // New face (a, b, c), counter-clockwise seen from outside; its neighbours
  // are linked by the caller. -1 if out of capacity or degenerate.
  int new_face(int a, int b, int c) { return new_face(a, b, c, w(c)); }
  // The same with vertex c's coordinates at hand (the new vertex of an
  // expansion: no reload of what was just stored).
  int new_face(int a, int b, int c, const V3& wc) {
    // One branch, almost never taken (`nfree_ == 0 && ...` is two, and
    // whether the free list is empty is unpredictable).
    if ((nfree_ | (kMaxFaces - nused_)) == 0) return -1;
    // A free slot if there is one, else a fresh one; branch-free (whether
    // the free list is empty is unpredictable). free_ is 1-based.
    const bool reuse = nfree_ > 0;
    const int f = reuse ? free_[nfree_] : nused_;
    nfree_ -= reuse;
    nused_ += !reuse;
    const V3 wa = w(a), wb = w(b);
    const V3 n = cross(wb - wa, wc - wa);
    const double len2 = norm2(n);
    if (!(len2 > area_eps2_)) {
      release(f);
      return -1;
    }
    const V3 u = n * (1.0 / std::sqrt(len2));
    nx_[f] = u.x;
    ny_[f] = u.y;
    nz_[f] = u.z;
    dist_[f] = dot(u, wa);
    FaceTopology& T = topo_[f];
    T.v[0] = static_cast<std::uint8_t>(a);
    T.v[1] = static_cast<std::uint8_t>(b);
    T.v[2] = static_cast<std::uint8_t>(c);
    T.pass = 0;
    return f;
  }

  void release(int f) {
    dist_[f] = INFINITY;
    free_[++nfree_] = static_cast<std::uint16_t>(f);
  }

  void link(int f, int e, int g, int h) {
    topo_[f].adj[e] = static_cast<std::uint16_t>(g * 4 + h);
    topo_[g].adj[h] = static_cast<std::uint16_t>(f * 4 + e);
  }

  double area_eps2_, plane_eps_;
  int nv_ = 0, nused_ = 0, nfree_ = 0, nremoved_ = 0;
  std::uint16_t pass_ = 0;
  // The polytope's vertices (points of D) and A's support point behind each.
  Uninitialised<double, kMaxVertices> wx_, wy_, wz_;
  Uninitialised<V3, kMaxVertices> a_;
  // Face planes: unit normal, and offset = distance from the origin (+inf
  // once the face is free: the closest-face scan reads only this array).
  Uninitialised<double, kMaxFaces> nx_, ny_, nz_, dist_;
  Uninitialised<FaceTopology, kMaxFaces + 1> topo_;  // + the horizon's scratch face
  std::uint16_t free_[kMaxFaces + 1];  // free slots, 1-based (free_[0] is read, never used)
  std::uint16_t removed_[kMaxFaces];
};

}  // namespace hbp::narrow::epa_detail
