// SPDX-License-Identifier: MIT
#pragma once
// A flat BVH over a BoxArray answering exact closed box and ray queries with
// the indices of the boxes. BroadPhase keeps one over its static objects
// (built when statics change) and one over its moving objects (built lazily
// for queries, refitted while the membership does not change).
//
// Built by the binned-SAH builder of hierarchy/cell_bvh (one box per leaf),
// then cut and collapsed into two kinds of block, each a whole number of
// cache lines:
// - Leaf (128 bytes): up to four objects, their exact boxes side by side
//   (SoA) with their indices and ids: one SSE test is the exact test of four
//   objects. A leaf is a binary subtree of at most four objects.
// - Node (128 bytes): up to eight children (nodes or leaves), their boxes
//   quantised to 8 bits per bound relative to the node's own box (origin lo,
//   step per axis), rounded outward: a child's decoded box contains its real
//   box, so the test is conservative and only a leaf's exact test reports.
//   Decoding is lo + q * step in float, the very operations the build
//   verified the rounding with.
// On a million boxes a query is bound by cache misses, not arithmetic: eight
// quantised children fit where four float ones did, so the walk is shallower
// (at most 9 blocks instead of 12 on the paper frame's 10^6 boxes), a
// leaf is four full-precision objects, and passing children are prefetched
// at once and tested first in, first out (traverse), so misses overlap.
#include <cstddef>
#include <cstdint>
#include <cstring>
#include <span>
#include <utility>
#include <vector>

#if defined(__SSE2__)
#include <emmintrin.h>
#endif
// The eight-lane node test of rays is an AVX2 function chosen at run time
// (the library is built for plain x86-64).
#include "support/cpu_features.hpp"
#if HBP_X86_64_GNU
#include <immintrin.h>
#endif

#include "hbp/aabb.hpp"
#include "hbp/box_array.hpp"
#include "hbp/limits.hpp"
#include "partition/raw_buffer.hpp"
#include "pipeline/box_cast.hpp"
#include "pipeline/ray_segment.hpp"

namespace hbp::detail {

class BoxTree {
 public:
  static constexpr std::uint32_t kWidth = 4;
  static constexpr std::uint32_t kNodeWidth = 8;
  // link of a leaf: kLeaf | leaf index; of a node: its index; kNone: unused lane.
  static constexpr std::uint32_t kLeaf = 0x80000000u;
  static constexpr std::uint32_t kNone = 0xffffffffu;
  // One more than the most boxes a tree holds (kMaxQueryTreeBoxes).
  static constexpr std::uint32_t kMaxBoxes = kLeaf;
  static_assert(kMaxBoxes - 1 == kMaxQueryTreeBoxes);
  static constexpr std::uint32_t kStack = 128;

  // An object found by a query: its box, index and the caller's id for it
  // (the id saves a query a random read per hit: the caller's index ->
  // handle table is as large as the tree).
  struct Item {
    float min[3];
    float max[3];
    std::uint32_t index;
    std::uint32_t id;
  };
  // Up to four objects, exact boxes SoA: min[axis][lane]; an unused lane has
  // index kNone and the empty box (+inf, -inf).
  struct alignas(64) Leaf {
    float min[3][kWidth];
    float max[3][kWidth];
    std::uint32_t index[kWidth];
    std::uint32_t id[kWidth];
  };
  static_assert(sizeof(Leaf) == 128, "a leaf is two cache lines");
  // Up to eight children; child c's decoded box on axis k is
  // [lo[k] + qmin[k][c] * step[k], lo[k] + qmax[k][c] * step[k]] (float).
  struct alignas(64) Node {
    float lo[3];
    float step[3];
    std::uint8_t qmin[3][kNodeWidth];
    std::uint8_t qmax[3][kNodeWidth];
    std::uint32_t link[kNodeWidth];
  };
  static_assert(sizeof(Node) == 128, "a node is two cache lines");

  // Rebuilds over every box of `boxes` (item index = box index, item id =
  // ids[index]; ids.size() == boxes.size() < kMaxBoxes).
  void build(const BoxArray& boxes, std::span<const std::uint32_t> ids);
  // Same membership, new boxes.
  void refit(const BoxArray& boxes);
  void clear();
  bool empty() const { return leaves_.size() == 0; }
  // Blocks on the longest root-to-leaf path (0 when empty); a walk keeps
  // kStack pending nodes before it recurses.
  std::uint32_t depth() const;
  // Bytes held (both arrays' capacity).
  std::size_t node_count() const { return nodes_.size(); }
  std::size_t leaf_count() const { return leaves_.size(); }
  std::size_t bytes() const { return nodes_.capacity() * sizeof(Node) + leaves_.capacity() * sizeof(Leaf); }

  // Calls hit(index, item) for every box overlapping the closed box q.
  template <class Hit>
  void for_each_overlap(const Aabb& q, Hit&& hit) const {
    if (empty()) return;
    const auto node_mask = [&](const Node& n) { return node_overlap_mask(n, q); };
    const auto visit_leaf = [&](std::uint32_t link) {
      const Leaf& l = leaves_[link & ~kLeaf];
      for (std::uint32_t m = leaf_overlap_mask(l, q); m; m &= m - 1) report(l, lane(m), hit);
    };
    traverse(root_, node_mask, visit_leaf);
  }

  // Calls hit(item, entry_t) for every box the segment touches.
  template <class Hit>
  void for_each_ray_hit(const RaySegment& ray, Hit&& hit) const {
    if (empty()) return;
    const RayLanes lanes(ray);
#if HBP_X86_64_GNU
    if (cpu_has_avx2()) return ray_walk_avx2(ray, lanes, hit);
#endif
    ray_walk_portable(ray, lanes, hit);
  }
  // The same walk with the four-lane (SSE2) node test whatever the CPU: what
  // CPUs without AVX2 run (the tests check both walks).
  template <class Hit>
  void for_each_ray_hit_portable(const RaySegment& ray, Hit&& hit) const {
    if (empty()) return;
    ray_walk_portable(ray, RayLanes(ray), hit);
  }

  // The nearest box the segment touches, folded into (best_t, best_id):
  // a hit (t, id) replaces them when t < best_t, or t == best_t and
  // id < best_id (start from +inf and kNone; ids are never kNone). The walk
  // goes nearest-first: a node's children are pushed farthest first by the
  // entry t of their decoded boxes, and a pending block whose entry t is
  // beyond best_t is dropped unread. A decoded box contains its objects and
  // the slab test is monotone in the bounds, so a block's entry t is <= the
  // entry t of every object below it: dropping it loses no better hit
  // (equal t is still opened, for the smaller id).
  // accept(id) (optional) says whether a hit counts (a query filter).
  void closest_ray_hit(const RaySegment& ray, float& best_t, std::uint32_t& best_id) const {
    closest_ray_hit(ray, best_t, best_id, [](std::uint32_t) { return true; });
  }
  template <class Accept>
  void closest_ray_hit(const RaySegment& ray, float& best_t, std::uint32_t& best_id, const Accept& accept) const {
    if (empty()) return;
    closest_walk(root_, 0.0f, ray, RayLanes(ray), best_t, best_id, accept);
  }

  // Calls hit(item, entry_t) for every box the cast box touches (BoxCast's
  // rule, entry_t its first t), in no particular order.
  template <class Hit>
  void for_each_cast_hit(const BoxCast& cast, Hit&& hit) const {
    if (empty()) return;
    const RayLanes lanes(cast.ray);
    const auto node_mask = [&](const Node& n) { return node_cast_mask(n, cast, lanes); };
    const auto visit_leaf = [&](std::uint32_t link) {
      const Leaf& l = leaves_[link & ~kLeaf];
      float entry[kWidth];
      for (std::uint32_t m = leaf_cast_mask(l, cast, lanes, entry); m; m &= m - 1) hit(item(l, lane(m)), entry[lane(m)]);
    };
    traverse(root_, node_mask, visit_leaf);
  }

  // The decoded (conservative) box of node n's lane c; also what build and
  // refit verify the rounding with.
  static void decode(const Node& n, std::uint32_t c, float mn[3], float mx[3]) {
    for (int k = 0; k < 3; ++k) {
      mn[k] = n.lo[k] + static_cast<float>(n.qmin[k][c]) * n.step[k];
      mx[k] = n.lo[k] + static_cast<float>(n.qmax[k][c]) * n.step[k];
    }
  }

 private:
  static constexpr std::uint32_t kRing = 8;
  static constexpr std::uint32_t kDeepStack = 32;

  static std::uint32_t lane(std::uint32_t mask) { return static_cast<std::uint32_t>(__builtin_ctz(mask)); }

  static bool overlaps(const float* mn, const float* mx, const Aabb& q) {
    return (mx[0] >= q.min[0]) & (mn[0] <= q.max[0]) & (mx[1] >= q.min[1]) & (mn[1] <= q.max[1]) &
           (mx[2] >= q.min[2]) & (mn[2] <= q.max[2]);
  }

  // Bit c: lane c holds a child / an object.
  static std::uint32_t used_mask(const std::uint32_t* link) {
#if defined(__SSE2__)
    const __m128i unused = _mm_cmpeq_epi32(_mm_loadu_si128(reinterpret_cast<const __m128i*>(link)), _mm_set1_epi32(-1));
    return static_cast<std::uint32_t>(_mm_movemask_ps(_mm_castsi128_ps(unused))) ^ 0xFu;
#else
    std::uint32_t mask = 0;
    for (std::uint32_t c = 0; c < kWidth; ++c) mask |= static_cast<std::uint32_t>(link[c] != kNone) << c;
    return mask;
#endif
  }

  static Item item(const Leaf& l, std::uint32_t c) {
    return {{l.min[0][c], l.min[1][c], l.min[2][c]}, {l.max[0][c], l.max[1][c], l.max[2][c]}, l.index[c], l.id[c]};
  }
  template <class Hit>
  static void report(const Leaf& l, std::uint32_t c, Hit& hit) {
    const Item it = item(l, c);
    hit(it.index, it);
  }

#if defined(__SSE2__)
  // Lanes h..h+3's decoded bounds on every axis: lo + q * step.
  static void decode_lanes(const Node& n, std::uint32_t h, __m128* mn, __m128* mx) {
    const __m128i zero = _mm_setzero_si128();
    for (int k = 0; k < 3; ++k) {
      const __m128 lo = _mm_set1_ps(n.lo[k]), step = _mm_set1_ps(n.step[k]);
      std::int32_t a, b;
      std::memcpy(&a, n.qmin[k] + h, 4);
      std::memcpy(&b, n.qmax[k] + h, 4);
      const __m128i ca = _mm_unpacklo_epi16(_mm_unpacklo_epi8(_mm_cvtsi32_si128(a), zero), zero);
      const __m128i cb = _mm_unpacklo_epi16(_mm_unpacklo_epi8(_mm_cvtsi32_si128(b), zero), zero);
      mn[k] = _mm_add_ps(lo, _mm_mul_ps(_mm_cvtepi32_ps(ca), step));
      mx[k] = _mm_add_ps(lo, _mm_mul_ps(_mm_cvtepi32_ps(cb), step));
    }
  }
  static std::uint32_t sse_overlap_mask(const __m128* mn, const __m128* mx, const Aabb& q) {
    __m128 m = _mm_and_ps(_mm_cmpge_ps(mx[0], _mm_set1_ps(q.min[0])), _mm_cmple_ps(mn[0], _mm_set1_ps(q.max[0])));
    for (int k = 1; k < 3; ++k)
      m = _mm_and_ps(m, _mm_and_ps(_mm_cmpge_ps(mx[k], _mm_set1_ps(q.min[k])), _mm_cmple_ps(mn[k], _mm_set1_ps(q.max[k]))));
    return static_cast<std::uint32_t>(_mm_movemask_ps(m));
  }
#endif

  // Bit c: leaf lane c's box overlaps the closed box q.
  static std::uint32_t leaf_overlap_mask(const Leaf& l, const Aabb& q) {
#if defined(__SSE2__)
    const __m128 mn[3] = {_mm_load_ps(l.min[0]), _mm_load_ps(l.min[1]), _mm_load_ps(l.min[2])};
    const __m128 mx[3] = {_mm_load_ps(l.max[0]), _mm_load_ps(l.max[1]), _mm_load_ps(l.max[2])};
    return sse_overlap_mask(mn, mx, q) & used_mask(l.index);
#else
    std::uint32_t mask = 0;
    for (std::uint32_t c = 0; c < kWidth; ++c) {
      const Item it = item(l, c);
      mask |= static_cast<std::uint32_t>(overlaps(it.min, it.max, q)) << c;
    }
    return mask & used_mask(l.index);
#endif
  }
  // Bit c: node lane c's decoded box overlaps q (every object under it that
  // overlaps q does, since the decoded box contains the child's).
  static std::uint32_t node_overlap_mask(const Node& n, const Aabb& q) {
#if defined(__SSE2__)
    std::uint32_t mask = 0;
    for (std::uint32_t h = 0; h < kNodeWidth; h += 4) {
      __m128 mn[3], mx[3];
      decode_lanes(n, h, mn, mx);
      mask |= sse_overlap_mask(mn, mx, q) << h;
    }
    return mask & (used_mask(n.link) | used_mask(n.link + 4) << 4);
#else
    std::uint32_t mask = 0;
    for (std::uint32_t c = 0; c < kNodeWidth; ++c) {
      float mn[3], mx[3];
      decode(n, c, mn, mx);
      mask |= static_cast<std::uint32_t>(overlaps(mn, mx, q)) << c;
    }
    return mask & (used_mask(n.link) | used_mask(n.link + 4) << 4);
#endif
  }

  // The ray's per-query constants for the four-lane slab test, computed once
  // a ray: the broadcast origin and inverse, and per axis which bound the
  // ray meets first (near: the min when the inverse is >= 0, else the max),
  // so a lane's slab is t_near = (near - o) / d, t_far = (far - o) / d with
  // no min / max to order them: for a box with min <= max that is exactly
  // min(a, b) and max(a, b) of RaySegment::hits (a product by a positive /
  // negative inverse is monotone increasing / decreasing), the same floats.
  struct RayLanes {
#if defined(__SSE2__)
    __m128 origin[3], inverse[3];
#endif
    bool near_is_max[3];  // the inverse is negative
    bool any_parallel;
    explicit RayLanes([[maybe_unused]] const RaySegment& ray) {
      any_parallel = false;
      for (int k = 0; k < 3; ++k) {
#if defined(__SSE2__)
        origin[k] = _mm_set1_ps(ray.origin[k]);
        inverse[k] = _mm_set1_ps(ray.inverse[k]);
#endif
        near_is_max[k] = !ray.parallel[k] && ray.inverse[k] < 0;
        any_parallel |= ray.parallel[k];
      }
    }
  };

#if defined(__SSE2__)
  // Four-lane slab test from the near and far bounds of each axis (RayLanes):
  // the arithmetic is RaySegment::hits' operation for operation (t_near is
  // its min(a, b), t_far its max(a, b), folded in the same order from
  // t0 = 0, t1 = max_t), so a leaf lane gives the very answer and t of the
  // scalar rule, and a node's decoded lane passes whenever one of the boxes
  // inside it would (rounding is monotone). A parallel axis tests the origin
  // against [min, max] (near / far are min / max there).
  static __m128 sse_ray_lanes(const __m128* nr, const __m128* fr, const RaySegment& ray, const RayLanes& lanes,
                              __m128& t0) {
    t0 = _mm_setzero_ps();
    __m128 t1 = _mm_set1_ps(ray.max_t);
    if (!lanes.any_parallel) {
      for (int k = 0; k < 3; ++k) {
        t0 = _mm_max_ps(t0, _mm_mul_ps(_mm_sub_ps(nr[k], lanes.origin[k]), lanes.inverse[k]));
        t1 = _mm_min_ps(t1, _mm_mul_ps(_mm_sub_ps(fr[k], lanes.origin[k]), lanes.inverse[k]));
      }
      return _mm_cmple_ps(t0, t1);
    }
    __m128 inside = _mm_castsi128_ps(_mm_set1_epi32(-1));
    for (int k = 0; k < 3; ++k) {
      if (ray.parallel[k]) {
        inside = _mm_and_ps(inside, _mm_and_ps(_mm_cmple_ps(nr[k], lanes.origin[k]), _mm_cmpge_ps(fr[k], lanes.origin[k])));
        continue;
      }
      t0 = _mm_max_ps(t0, _mm_mul_ps(_mm_sub_ps(nr[k], lanes.origin[k]), lanes.inverse[k]));
      t1 = _mm_min_ps(t1, _mm_mul_ps(_mm_sub_ps(fr[k], lanes.origin[k]), lanes.inverse[k]));
    }
    return _mm_and_ps(inside, _mm_cmple_ps(t0, t1));
  }
  // Lanes h..h+3's decoded near and far bounds on every axis.
  static void decode_ray_lanes(const Node& n, std::uint32_t h, const RayLanes& lanes, __m128* nr, __m128* fr) {
    const __m128i zero = _mm_setzero_si128();
    for (int k = 0; k < 3; ++k) {
      const __m128 lo = _mm_set1_ps(n.lo[k]), step = _mm_set1_ps(n.step[k]);
      const std::uint8_t* qn = lanes.near_is_max[k] ? n.qmax[k] : n.qmin[k];
      const std::uint8_t* qf = lanes.near_is_max[k] ? n.qmin[k] : n.qmax[k];
      std::int32_t a, b;
      std::memcpy(&a, qn + h, 4);
      std::memcpy(&b, qf + h, 4);
      const __m128i ca = _mm_unpacklo_epi16(_mm_unpacklo_epi8(_mm_cvtsi32_si128(a), zero), zero);
      const __m128i cb = _mm_unpacklo_epi16(_mm_unpacklo_epi8(_mm_cvtsi32_si128(b), zero), zero);
      nr[k] = _mm_add_ps(lo, _mm_mul_ps(_mm_cvtepi32_ps(ca), step));
      fr[k] = _mm_add_ps(lo, _mm_mul_ps(_mm_cvtepi32_ps(cb), step));
    }
  }
#endif

  // Bit c: the segment touches leaf lane c's box; entry[c] its entry t.
  static std::uint32_t leaf_ray_mask(const Leaf& l, const RaySegment& ray, [[maybe_unused]] const RayLanes& lanes,
                                     float* entry) {
#if defined(__SSE2__)
    __m128 nr[3], fr[3];
    for (int k = 0; k < 3; ++k) {
      nr[k] = _mm_load_ps(lanes.near_is_max[k] ? l.max[k] : l.min[k]);
      fr[k] = _mm_load_ps(lanes.near_is_max[k] ? l.min[k] : l.max[k]);
    }
    __m128 t0;
    const __m128 m = sse_ray_lanes(nr, fr, ray, lanes, t0);
    _mm_storeu_ps(entry, t0);
    return static_cast<std::uint32_t>(_mm_movemask_ps(m)) & used_mask(l.index);
#else
    std::uint32_t mask = 0;
    for (std::uint32_t c = 0; c < kWidth; ++c) {
      const Item it = item(l, c);
      mask |= static_cast<std::uint32_t>(ray.hits(it.min, it.max, entry[c])) << c;
    }
    return mask & used_mask(l.index);
#endif
  }
  // Bit c: the segment touches node lane c's decoded box.
  static std::uint32_t node_ray_mask(const Node& n, const RaySegment& ray, [[maybe_unused]] const RayLanes& lanes) {
#if defined(__SSE2__)
    std::uint32_t mask = 0;
    for (std::uint32_t h = 0; h < kNodeWidth; h += 4) {
      __m128 nr[3], fr[3];
      decode_ray_lanes(n, h, lanes, nr, fr);
      __m128 t0;
      mask |= static_cast<std::uint32_t>(_mm_movemask_ps(sse_ray_lanes(nr, fr, ray, lanes, t0))) << h;
    }
    return mask & (used_mask(n.link) | used_mask(n.link + 4) << 4);
#else
    std::uint32_t mask = 0;
    for (std::uint32_t c = 0; c < kNodeWidth; ++c) {
      float mn[3], mx[3], t;
      decode(n, c, mn, mx);
      mask |= static_cast<std::uint32_t>(ray.hits(mn, mx, t)) << c;
    }
    return mask & (used_mask(n.link) | used_mask(n.link + 4) << 4);
#endif
  }

  // Bit c: the segment touches node lane c's decoded box; entry[c] its
  // entry t (meaningful for passing lanes).
  static std::uint32_t node_ray_entry_mask(const Node& n, const RaySegment& ray, [[maybe_unused]] const RayLanes& lanes,
                                           float* entry) {
#if defined(__SSE2__)
    std::uint32_t mask = 0;
    for (std::uint32_t h = 0; h < kNodeWidth; h += 4) {
      __m128 nr[3], fr[3];
      decode_ray_lanes(n, h, lanes, nr, fr);
      __m128 t0;
      mask |= static_cast<std::uint32_t>(_mm_movemask_ps(sse_ray_lanes(nr, fr, ray, lanes, t0))) << h;
      _mm_storeu_ps(entry + h, t0);
    }
    return mask & (used_mask(n.link) | used_mask(n.link + 4) << 4);
#else
    std::uint32_t mask = 0;
    for (std::uint32_t c = 0; c < kNodeWidth; ++c) {
      float mn[3], mx[3];
      decode(n, c, mn, mx);
      mask |= static_cast<std::uint32_t>(ray.hits(mn, mx, entry[c])) << c;
    }
    return mask & (used_mask(n.link) | used_mask(n.link + 4) << 4);
#endif
  }

  // closest_ray_hit's walk of the subtree at `link` (entry t `t`). Pending
  // blocks sit on a stack with their entry t, nearest on top; a stack full
  // (a degenerate tree far deeper than SAH builds) walks the child apart.
  static constexpr std::uint32_t kClosestStack = 256;
  template <class Accept>
  __attribute__((noinline)) void closest_walk(std::uint32_t link, float t, const RaySegment& ray,
                                              const RayLanes& lanes, float& best_t, std::uint32_t& best_id,
                                              const Accept& accept) const {
    struct Pending {
      std::uint32_t link;
      float t;
    };
    Pending stack[kClosestStack];
    std::uint32_t top = 0;
    stack[top++] = {link, t};
    while (top != 0) {
      const Pending p = stack[--top];
      if (p.t > best_t) continue;
      if (p.link & kLeaf) {
        const Leaf& l = leaves_[p.link & ~kLeaf];
        float entry[kWidth];
        for (std::uint32_t m = leaf_ray_mask(l, ray, lanes, entry); m; m &= m - 1) {
          const std::uint32_t c = lane(m);
          if ((entry[c] < best_t || (entry[c] == best_t && l.id[c] < best_id)) && accept(l.id[c])) {
            best_t = entry[c];
            best_id = l.id[c];
          }
        }
        continue;
      }
      const Node& n = nodes_[p.link];
      float entry[kNodeWidth];
      Pending kids[kNodeWidth];
      std::uint32_t count = 0;
      for (std::uint32_t m = node_ray_entry_mask(n, ray, lanes, entry); m; m &= m - 1) {
        const std::uint32_t c = lane(m);
        if (entry[c] > best_t) continue;
        // Insertion by descending t: the nearest child ends on top.
        std::uint32_t i = count++;
        for (; i > 0 && kids[i - 1].t < entry[c]; --i) kids[i] = kids[i - 1];
        kids[i] = {n.link[c], entry[c]};
        prefetch(n.link[c]);
      }
      for (std::uint32_t i = 0; i < count; ++i) {
        if (top == kClosestStack)
          closest_walk(kids[i].link, kids[i].t, ray, lanes, best_t, best_id, accept);
        else
          stack[top++] = kids[i];
      }
    }
  }

  // The cast's slab test on grown bounds: lanes' [mn - box.max, mx - box.min]
  // against the segment from 0 (RayLanes of cast.ray), the same floats as
  // BoxCast::hits (x - 0 is x).
#if defined(__SSE2__)
  static __m128 sse_cast_lanes(const __m128* mn, const __m128* mx, const BoxCast& cast, const RayLanes& lanes,
                               __m128& t0) {
    __m128 nr[3], fr[3];
    for (int k = 0; k < 3; ++k) {
      const __m128 gmn = _mm_sub_ps(mn[k], _mm_set1_ps(cast.box.max[k]));
      const __m128 gmx = _mm_sub_ps(mx[k], _mm_set1_ps(cast.box.min[k]));
      nr[k] = lanes.near_is_max[k] ? gmx : gmn;
      fr[k] = lanes.near_is_max[k] ? gmn : gmx;
    }
    return sse_ray_lanes(nr, fr, cast.ray, lanes, t0);
  }
#endif
  static std::uint32_t leaf_cast_mask(const Leaf& l, const BoxCast& cast, [[maybe_unused]] const RayLanes& lanes,
                                      float* entry) {
#if defined(__SSE2__)
    const __m128 mn[3] = {_mm_load_ps(l.min[0]), _mm_load_ps(l.min[1]), _mm_load_ps(l.min[2])};
    const __m128 mx[3] = {_mm_load_ps(l.max[0]), _mm_load_ps(l.max[1]), _mm_load_ps(l.max[2])};
    __m128 t0;
    const __m128 m = sse_cast_lanes(mn, mx, cast, lanes, t0);
    _mm_storeu_ps(entry, t0);
    return static_cast<std::uint32_t>(_mm_movemask_ps(m)) & used_mask(l.index);
#else
    std::uint32_t mask = 0;
    for (std::uint32_t c = 0; c < kWidth; ++c) {
      const Item it = item(l, c);
      mask |= static_cast<std::uint32_t>(cast.hits(it.min, it.max, entry[c])) << c;
    }
    return mask & used_mask(l.index);
#endif
  }
  static std::uint32_t node_cast_mask(const Node& n, const BoxCast& cast, [[maybe_unused]] const RayLanes& lanes) {
#if defined(__SSE2__)
    std::uint32_t mask = 0;
    for (std::uint32_t h = 0; h < kNodeWidth; h += 4) {
      __m128 mn[3], mx[3], t0;
      decode_lanes(n, h, mn, mx);
      mask |= static_cast<std::uint32_t>(_mm_movemask_ps(sse_cast_lanes(mn, mx, cast, lanes, t0))) << h;
    }
    return mask & (used_mask(n.link) | used_mask(n.link + 4) << 4);
#else
    std::uint32_t mask = 0;
    for (std::uint32_t c = 0; c < kNodeWidth; ++c) {
      float mn[3], mx[3], t;
      decode(n, c, mn, mx);
      mask |= static_cast<std::uint32_t>(cast.hits(mn, mx, t)) << c;
    }
    return mask & (used_mask(n.link) | used_mask(n.link + 4) << 4);
#endif
  }

  void prefetch(std::uint32_t link) const {
    if (link & kLeaf) {
      const char* p = reinterpret_cast<const char*>(&leaves_[link & ~kLeaf]);
      __builtin_prefetch(p);
      __builtin_prefetch(p + 64);
    } else {
      const char* p = reinterpret_cast<const char*>(&nodes_[link]);
      __builtin_prefetch(p);
      __builtin_prefetch(p + 64);
    }
  }

  // Walk of the subtree at `link`: node_mask(node) gives the passing lanes,
  // visit_leaf(link) tests a leaf. A passing child is prefetched at once and
  // queued in a small ring that is served first in, first out, so by the time
  // a block is tested its miss has overlapped the tests of up to kRing blocks
  // queued before it (a plain depth-first walk tests the child it has just
  // asked for, and waits). Children that find the ring full go on a stack,
  // served when the ring is empty or the stack holds more than kDeepStack
  // (then the walk is depth-first, which bounds the stack by the depth).
  //
  // Always inlined, so that inside the AVX2 ray walk (ray_walk_avx2) the
  // walk and its tests are one AVX2 function.
  template <class NodeMask, class VisitLeaf>
  __attribute__((always_inline)) inline void traverse(std::uint32_t link, const NodeMask& node_mask,
                                                      const VisitLeaf& visit_leaf) const {
    std::uint32_t stack[kStack];
    std::uint32_t top = 0;
    std::uint32_t ring[kRing];
    std::uint32_t head = 0, tail = 0;
    for (;;) {
      if (link & kLeaf) {
        visit_leaf(link);
      } else {
        const Node& n = nodes_[link];
        for (std::uint32_t m = node_mask(n); m; m &= m - 1) {
          const std::uint32_t child = n.link[lane(m)];
          prefetch(child);
          if (tail - head < kRing)
            ring[tail++ % kRing] = child;
          else if (top == kStack)  // deeper than any SAH tree of 2^31 boxes: a fresh walk
            traverse_apart(child, node_mask, visit_leaf);
          else
            stack[top++] = child;
        }
      }
      if (head != tail && top <= kDeepStack)
        link = ring[head++ % kRing];
      else if (top != 0)
        link = stack[--top];
      else
        return;
    }
  }

  template <class NodeMask, class VisitLeaf>
  __attribute__((noinline)) void traverse_apart(std::uint32_t link, const NodeMask& node_mask,
                                                const VisitLeaf& visit_leaf) const {
    traverse(link, node_mask, visit_leaf);
  }

  // for_each_ray_hit's walk with the four-lane node test.
  template <class Hit>
  void ray_walk_portable(const RaySegment& ray, const RayLanes& lanes, Hit& hit) const {
    const auto node_mask = [&](const Node& n) { return node_ray_mask(n, ray, lanes); };
    const auto visit_leaf = [&](std::uint32_t link) {
      const Leaf& l = leaves_[link & ~kLeaf];
      float entry[kWidth];
      for (std::uint32_t m = leaf_ray_mask(l, ray, lanes, entry); m; m &= m - 1) hit(item(l, lane(m)), entry[lane(m)]);
    };
    traverse(root_, node_mask, visit_leaf);
  }

#if HBP_X86_64_GNU
  // Node test of a ray in eight lanes at once: the SSE test's operations
  // (decode lo + q * step, then the near / far slab) on a 256-bit vector, no
  // FMA (not enabled here), so the very same floats.
  struct Avx2NodeRayMask {
    const RaySegment& ray;
    const RayLanes& lanes;
    __attribute__((target("avx2"))) std::uint32_t operator()(const Node& n) const {
      __m256 t0 = _mm256_setzero_ps();
      __m256 t1 = _mm256_set1_ps(ray.max_t);
      __m256 inside = _mm256_castsi256_ps(_mm256_set1_epi32(-1));
      for (int k = 0; k < 3; ++k) {
        const __m256 lo = _mm256_set1_ps(n.lo[k]), step = _mm256_set1_ps(n.step[k]);
        const std::uint8_t* qn = lanes.near_is_max[k] ? n.qmax[k] : n.qmin[k];
        const std::uint8_t* qf = lanes.near_is_max[k] ? n.qmin[k] : n.qmax[k];
        const __m256i cn = _mm256_cvtepu8_epi32(_mm_loadl_epi64(reinterpret_cast<const __m128i*>(qn)));
        const __m256i cf = _mm256_cvtepu8_epi32(_mm_loadl_epi64(reinterpret_cast<const __m128i*>(qf)));
        const __m256 nr = _mm256_add_ps(lo, _mm256_mul_ps(_mm256_cvtepi32_ps(cn), step));
        const __m256 fr = _mm256_add_ps(lo, _mm256_mul_ps(_mm256_cvtepi32_ps(cf), step));
        const __m256 o = _mm256_set1_ps(ray.origin[k]);
        if (lanes.any_parallel && ray.parallel[k]) {
          inside = _mm256_and_ps(inside, _mm256_and_ps(_mm256_cmp_ps(nr, o, _CMP_LE_OQ), _mm256_cmp_ps(fr, o, _CMP_GE_OQ)));
          continue;
        }
        const __m256 inv = _mm256_set1_ps(ray.inverse[k]);
        t0 = _mm256_max_ps(t0, _mm256_mul_ps(_mm256_sub_ps(nr, o), inv));
        t1 = _mm256_min_ps(t1, _mm256_mul_ps(_mm256_sub_ps(fr, o), inv));
      }
      const __m256 pass = _mm256_and_ps(inside, _mm256_cmp_ps(t0, t1, _CMP_LE_OQ));
      const __m256i unused =
          _mm256_cmpeq_epi32(_mm256_loadu_si256(reinterpret_cast<const __m256i*>(n.link)), _mm256_set1_epi32(-1));
      return static_cast<std::uint32_t>(_mm256_movemask_ps(_mm256_andnot_ps(_mm256_castsi256_ps(unused), pass)));
    }
  };

  // for_each_ray_hit's walk as one AVX2 function (traverse and the tests
  // inline into it; the leaf test is the SSE one, VEX-encoded).
  template <class Hit>
  __attribute__((target("avx2"))) void ray_walk_avx2(const RaySegment& ray, const RayLanes& lanes, Hit& hit) const {
    const Avx2NodeRayMask node_mask{ray, lanes};
    const auto visit_leaf = [&](std::uint32_t link) {
      const Leaf& l = leaves_[link & ~kLeaf];
      float entry[kWidth];
      for (std::uint32_t m = leaf_ray_mask(l, ray, lanes, entry); m; m &= m - 1) hit(item(l, lane(m)), entry[lane(m)]);
    };
    traverse(root_, node_mask, visit_leaf);
  }
#endif

  // On huge pages when large (RawBuffer): a query's random walk over tens of
  // megabytes would otherwise miss the TLB at almost every block.
  RawBuffer<Node> nodes_;    // a node before its descendants
  RawBuffer<Leaf> leaves_;   // a node's leaf children side by side
  std::uint32_t root_ = kNone;  // link of the root (a leaf when <= 4 boxes)
};

}  // namespace hbp::detail
