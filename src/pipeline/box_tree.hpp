#pragma once
// A flat 4-wide BVH over a BoxArray answering exact closed box and ray
// queries with the indices of the boxes. BroadPhase keeps one over its static
// objects (built when statics change) and one over its moving objects (built
// lazily for queries, refitted while the membership does not change).
//
// Built by the binned-SAH builder of hierarchy/cell_bvh (one box per leaf),
// then collapsed twice: every subtree of at most kLeafSize boxes becomes one
// leaf whose boxes are stored contiguously (Item), and every internal node
// takes up to four children (its grandchildren with the largest surface
// area), their boxes side by side (SoA) so one node tests all four at once.
// On a million boxes a query is bound by cache misses, not arithmetic: half
// the depth of a binary tree is half the misses, and a node's children are
// prefetched as soon as they pass, so their misses overlap.
#include <cstdint>
#include <span>
#include <utility>
#include <vector>

#if defined(__SSE2__)
#include <emmintrin.h>
#endif

#include "hbp/aabb.hpp"
#include "hbp/box_array.hpp"
#include "pipeline/ray_segment.hpp"

namespace hbp::detail {

class BoxTree {
 public:
  static constexpr std::uint32_t kLeafSize = 4;
  static constexpr std::uint32_t kWidth = 4;

  // A box, its index and the caller's id for it: the leaves' contents, in
  // tree order. The id saves a query a random read per hit (the caller's
  // index -> handle table is as large as the tree).
  struct Item {
    float min[3];
    float max[3];
    std::uint32_t index;
    std::uint32_t id;
  };
  // Up to four children, boxes SoA: min[axis][child]. Child c (c < used) is
  // a node index when count[c] == 0, else a leaf of items
  // [link[c], link[c] + count[c]). Unused slots hold an empty box
  // (+inf, -inf), which no closed box overlaps; rays mask them by `used`.
  struct alignas(64) Node {
    float min[3][kWidth];
    float max[3][kWidth];
    std::uint32_t link[kWidth];
    std::uint8_t count[kWidth];
    std::uint32_t used;
    std::uint32_t pad[2];
  };
  static_assert(sizeof(Node) == 128 && sizeof(Item) == 32);

  // Rebuilds over every box of `boxes` (item index = box index, item id =
  // ids[index]; ids.size() == boxes.size()).
  void build(const BoxArray& boxes, std::span<const std::uint32_t> ids);
  // Same membership, new boxes.
  void refit(const BoxArray& boxes);
  void clear();
  bool empty() const { return items_.empty(); }

  // Calls hit(index, item) for every box overlapping the closed box q.
  template <class Hit>
  void for_each_overlap(const Aabb& q, Hit&& hit) const {
    if (items_.empty()) return;
    if (nodes_.empty()) {  // a single leaf: no node above it
      leaf_overlap(0, static_cast<std::uint32_t>(items_.size()), q, hit);
      return;
    }
    std::uint32_t stack[kStack];
    std::uint32_t top = 0;
    std::uint32_t i = 0;
    for (;;) {
      const Node& n = nodes_[i];
      std::uint32_t mask = overlap_mask(n, q);
      prefetch_children(n, mask);
      while (mask) {
        const auto c = static_cast<std::uint32_t>(__builtin_ctz(mask));
        mask &= mask - 1;
        if (n.count[c]) {
          leaf_overlap(n.link[c], n.count[c], q, hit);
        } else if (top == kStack) {  // deeper than any SAH tree of 2^32 boxes: walk the rest recursively
          walk_overlap(n.link[c], q, hit);
        } else {
          stack[top++] = n.link[c];
        }
      }
      if (top == 0) return;
      i = stack[--top];
    }
  }

  // Calls hit(item, entry_t) for every box the segment touches.
  template <class Hit>
  void for_each_ray_hit(const RaySegment& ray, Hit&& hit) const {
    if (items_.empty()) return;
    if (nodes_.empty()) {
      leaf_ray(0, static_cast<std::uint32_t>(items_.size()), ray, hit);
      return;
    }
    const RayLanes lanes(ray);
    std::uint32_t stack[kStack];
    std::uint32_t top = 0;
    std::uint32_t i = 0;
    for (;;) {
      const Node& n = nodes_[i];
      std::uint32_t mask = ray_mask(n, ray, lanes);
      prefetch_children(n, mask);
      while (mask) {
        const auto c = static_cast<std::uint32_t>(__builtin_ctz(mask));
        mask &= mask - 1;
        if (n.count[c]) {
          leaf_ray(n.link[c], n.count[c], ray, hit);
        } else if (top == kStack) {
          walk_ray(n.link[c], ray, lanes, hit);
        } else {
          stack[top++] = n.link[c];
        }
      }
      if (top == 0) return;
      i = stack[--top];
    }
  }

 private:
  static constexpr std::uint32_t kStack = 128;

  static bool overlaps(const float* mn, const float* mx, const Aabb& q) {
    return (mx[0] >= q.min[0]) & (mn[0] <= q.max[0]) & (mx[1] >= q.min[1]) & (mn[1] <= q.max[1]) &
           (mx[2] >= q.min[2]) & (mn[2] <= q.max[2]);
  }

  // Bit c: child c's box overlaps the closed box q.
  static std::uint32_t overlap_mask(const Node& n, const Aabb& q) {
#if defined(__SSE2__)
    __m128 m = _mm_and_ps(_mm_cmpge_ps(_mm_load_ps(n.max[0]), _mm_set1_ps(q.min[0])),
                          _mm_cmple_ps(_mm_load_ps(n.min[0]), _mm_set1_ps(q.max[0])));
    for (int k = 1; k < 3; ++k)
      m = _mm_and_ps(m, _mm_and_ps(_mm_cmpge_ps(_mm_load_ps(n.max[k]), _mm_set1_ps(q.min[k])),
                                   _mm_cmple_ps(_mm_load_ps(n.min[k]), _mm_set1_ps(q.max[k]))));
    return static_cast<std::uint32_t>(_mm_movemask_ps(m));
#else
    std::uint32_t mask = 0;
    for (std::uint32_t c = 0; c < kWidth; ++c) {
      const float mn[3] = {n.min[0][c], n.min[1][c], n.min[2][c]};
      const float mx[3] = {n.max[0][c], n.max[1][c], n.max[2][c]};
      mask |= static_cast<std::uint32_t>(overlaps(mn, mx, q)) << c;
    }
    return mask;
#endif
  }

  // The ray's per-query constants for the four-lane slab test; the
  // arithmetic is RaySegment::hits' (same operations, same rounding), so a
  // node passes whenever one of its boxes would.
  struct RayLanes {
#if defined(__SSE2__)
    __m128 origin[3], inverse[3];
#endif
    explicit RayLanes([[maybe_unused]] const RaySegment& ray) {
#if defined(__SSE2__)
      for (int k = 0; k < 3; ++k) {
        origin[k] = _mm_set1_ps(ray.origin[k]);
        inverse[k] = _mm_set1_ps(ray.inverse[k]);
      }
#endif
    }
  };

  static std::uint32_t ray_mask(const Node& n, const RaySegment& ray, [[maybe_unused]] const RayLanes& lanes) {
#if defined(__SSE2__)
    __m128 t0 = _mm_setzero_ps(), t1 = _mm_set1_ps(ray.max_t);
    __m128 inside = _mm_castsi128_ps(_mm_set1_epi32(-1));
    for (int k = 0; k < 3; ++k) {
      const __m128 mn = _mm_load_ps(n.min[k]), mx = _mm_load_ps(n.max[k]);
      if (ray.parallel[k]) {
        inside = _mm_and_ps(inside, _mm_and_ps(_mm_cmple_ps(mn, lanes.origin[k]), _mm_cmpge_ps(mx, lanes.origin[k])));
        continue;
      }
      const __m128 a = _mm_mul_ps(_mm_sub_ps(mn, lanes.origin[k]), lanes.inverse[k]);
      const __m128 b = _mm_mul_ps(_mm_sub_ps(mx, lanes.origin[k]), lanes.inverse[k]);
      t0 = _mm_max_ps(t0, _mm_min_ps(a, b));
      t1 = _mm_min_ps(t1, _mm_max_ps(a, b));
    }
    const __m128 m = _mm_and_ps(inside, _mm_cmple_ps(t0, t1));
    return static_cast<std::uint32_t>(_mm_movemask_ps(m)) & ((1u << n.used) - 1);
#else
    std::uint32_t mask = 0;
    float t;
    for (std::uint32_t c = 0; c < n.used; ++c) {
      const float mn[3] = {n.min[0][c], n.min[1][c], n.min[2][c]};
      const float mx[3] = {n.max[0][c], n.max[1][c], n.max[2][c]};
      mask |= static_cast<std::uint32_t>(ray.hits(mn, mx, t)) << c;
    }
    return mask;
#endif
  }

  void prefetch_children(const Node& n, std::uint32_t mask) const {
    while (mask) {
      const auto c = static_cast<std::uint32_t>(__builtin_ctz(mask));
      mask &= mask - 1;
      if (n.count[c]) {
        const char* p = reinterpret_cast<const char*>(&items_[n.link[c]]);
        __builtin_prefetch(p);
        __builtin_prefetch(p + 64);
      } else {
        const char* p = reinterpret_cast<const char*>(&nodes_[n.link[c]]);
        __builtin_prefetch(p);
        __builtin_prefetch(p + 64);
      }
    }
  }

  template <class Hit>
  void leaf_overlap(std::uint32_t first, std::uint32_t count, const Aabb& q, Hit& hit) const {
    for (std::uint32_t k = first; k < first + count; ++k)
      if (overlaps(items_[k].min, items_[k].max, q)) hit(items_[k].index, items_[k]);
  }
  template <class Hit>
  void leaf_ray(std::uint32_t first, std::uint32_t count, const RaySegment& ray, Hit& hit) const {
    float t;
    for (std::uint32_t k = first; k < first + count; ++k)
      if (ray.hits(items_[k].min, items_[k].max, t)) hit(items_[k], t);
  }

  // The subtree at `root`, recursively (only past kStack levels).
  template <class Hit>
  void walk_overlap(std::uint32_t root, const Aabb& q, Hit& hit) const {
    const Node& n = nodes_[root];
    std::uint32_t mask = overlap_mask(n, q);
    while (mask) {
      const auto c = static_cast<std::uint32_t>(__builtin_ctz(mask));
      mask &= mask - 1;
      if (n.count[c])
        leaf_overlap(n.link[c], n.count[c], q, hit);
      else
        walk_overlap(n.link[c], q, hit);
    }
  }
  template <class Hit>
  void walk_ray(std::uint32_t root, const RaySegment& ray, const RayLanes& lanes, Hit& hit) const {
    const Node& n = nodes_[root];
    std::uint32_t mask = ray_mask(n, ray, lanes);
    while (mask) {
      const auto c = static_cast<std::uint32_t>(__builtin_ctz(mask));
      mask &= mask - 1;
      if (n.count[c])
        leaf_ray(n.link[c], n.count[c], ray, hit);
      else
        walk_ray(n.link[c], ray, lanes, hit);
    }
  }

  std::vector<Node> nodes_;  // root at 0; empty when every box fits one leaf
  std::vector<Item> items_;
};

}  // namespace hbp::detail
