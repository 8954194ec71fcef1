#pragma once
// A flat 4-wide BVH over a BoxArray answering exact closed box and ray
// queries with the indices of the boxes. BroadPhase keeps one over its static
// objects (built when statics change) and one over its moving objects (built
// lazily for queries, refitted while the membership does not change).
//
// Built by the binned-SAH builder of hierarchy/cell_bvh (one box per leaf),
// then collapsed: every node takes up to four children (opening the
// grandchild of largest surface area first), their boxes side by side (SoA)
// so one SSE test covers all four. A child is another node or one object,
// whose exact box is the lane's box: the node test is the object test, with
// no item array to fetch and no data-dependent branch per object.
// On a million boxes a query is bound by cache misses, not arithmetic: a
// quarter of a binary tree's depth is far fewer misses, and a node's
// children are prefetched as soon as they pass, so their misses overlap.
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
  static constexpr std::uint32_t kWidth = 4;
  // link of an object child: kObject | its box index.
  static constexpr std::uint32_t kObject = 0x80000000u;
  // The most boxes a tree holds (indices below kObject).
  static constexpr std::uint32_t kMaxBoxes = kObject;

  // An object found by a query: its box, index and the caller's id for it
  // (the id saves a query a random read per hit: the caller's index ->
  // handle table is as large as the tree).
  struct Item {
    float min[3];
    float max[3];
    std::uint32_t index;
    std::uint32_t id;
  };
  // Up to four children, boxes SoA: min[axis][lane]. link[lane]: a node
  // index (> 0: the root is nobody's child), kObject | box index, or 0 for
  // an unused lane, whose box is empty (+inf, -inf): no closed box overlaps
  // it, rays mask it. id[lane]: an object's id.
  struct alignas(64) Node {
    float min[3][kWidth];
    float max[3][kWidth];
    std::uint32_t link[kWidth];
    std::uint32_t id[kWidth];
  };
  static_assert(sizeof(Node) == 128, "a node is two cache lines");

  // Rebuilds over every box of `boxes` (item index = box index, item id =
  // ids[index]; ids.size() == boxes.size() < kMaxBoxes).
  void build(const BoxArray& boxes, std::span<const std::uint32_t> ids);
  // Same membership, new boxes.
  void refit(const BoxArray& boxes);
  void clear();
  bool empty() const { return nodes_.empty(); }

  // Calls hit(index, item) for every box overlapping the closed box q.
  template <class Hit>
  void for_each_overlap(const Aabb& q, Hit&& hit) const {
    if (nodes_.empty()) return;
    std::uint32_t stack[kStack];
    std::uint32_t top = 0;
    std::uint32_t i = 0;
    for (;;) {
      const Node& n = nodes_[i];
      const std::uint32_t mask = overlap_mask(n, q);
      const std::uint32_t objects = object_mask(n);
      for (std::uint32_t m = mask & objects; m; m &= m - 1) report(n, lane(m), hit);
      for (std::uint32_t m = mask & ~objects; m; m &= m - 1) {
        const std::uint32_t child = n.link[lane(m)];
        prefetch(child);
        if (top == kStack)  // deeper than any SAH tree of 2^31 boxes: walk the rest recursively
          walk_overlap(child, q, hit);
        else
          stack[top++] = child;
      }
      if (top == 0) return;
      i = stack[--top];
    }
  }

  // Calls hit(item, entry_t) for every box the segment touches.
  template <class Hit>
  void for_each_ray_hit(const RaySegment& ray, Hit&& hit) const {
    if (nodes_.empty()) return;
    const RayLanes lanes(ray);
    std::uint32_t stack[kStack];
    std::uint32_t top = 0;
    std::uint32_t i = 0;
    for (;;) {
      const Node& n = nodes_[i];
      float entry[kWidth];
      const std::uint32_t mask = ray_mask(n, ray, lanes, entry);
      const std::uint32_t objects = object_mask(n);
      for (std::uint32_t m = mask & objects; m; m &= m - 1) report_ray(n, lane(m), entry, hit);
      for (std::uint32_t m = mask & ~objects; m; m &= m - 1) {
        const std::uint32_t child = n.link[lane(m)];
        prefetch(child);
        if (top == kStack)
          walk_ray(child, ray, lanes, hit);
        else
          stack[top++] = child;
      }
      if (top == 0) return;
      i = stack[--top];
    }
  }

 private:
  static constexpr std::uint32_t kStack = 128;

  static std::uint32_t lane(std::uint32_t mask) { return static_cast<std::uint32_t>(__builtin_ctz(mask)); }

  static bool overlaps(const float* mn, const float* mx, const Aabb& q) {
    return (mx[0] >= q.min[0]) & (mn[0] <= q.max[0]) & (mx[1] >= q.min[1]) & (mn[1] <= q.max[1]) &
           (mx[2] >= q.min[2]) & (mn[2] <= q.max[2]);
  }

  // Bit c: lane c holds an object.
  static std::uint32_t object_mask(const Node& n) {
    std::uint32_t mask = 0;
    for (std::uint32_t c = 0; c < kWidth; ++c) mask |= (n.link[c] >> 31) << c;
    return mask;
  }
  // Bit c: lane c is used.
  static std::uint32_t used_mask(const Node& n) {
    std::uint32_t mask = 0;
    for (std::uint32_t c = 0; c < kWidth; ++c) mask |= static_cast<std::uint32_t>(n.link[c] != 0) << c;
    return mask;
  }

  static Item item(const Node& n, std::uint32_t c) {
    return {{n.min[0][c], n.min[1][c], n.min[2][c]}, {n.max[0][c], n.max[1][c], n.max[2][c]}, n.link[c] & ~kObject,
            n.id[c]};
  }
  template <class Hit>
  static void report(const Node& n, std::uint32_t c, Hit& hit) {
    const Item it = item(n, c);
    hit(it.index, it);
  }
  template <class Hit>
  static void report_ray(const Node& n, std::uint32_t c, const float* entry, Hit& hit) {
    hit(item(n, c), entry[c]);
  }

  // Bit c: lane c's box overlaps the closed box q (unused lanes never do).
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
      const Item it = item(n, c);
      mask |= static_cast<std::uint32_t>(overlaps(it.min, it.max, q)) << c;
    }
    return mask;
#endif
  }

  // The ray's per-query constants for the four-lane slab test.
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

  // Bit c: the segment touches lane c's box; entry[c] its entry t. The
  // arithmetic is RaySegment::hits' operation for operation (min(a, b) is
  // the swapped a, max the same order from t = 0), so an object's lane gives
  // the very answer and t of the scalar rule, and a node's lane passes
  // whenever one of its boxes would (rounding is monotone).
  static std::uint32_t ray_mask(const Node& n, const RaySegment& ray, [[maybe_unused]] const RayLanes& lanes,
                                float* entry) {
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
    _mm_storeu_ps(entry, t0);
    const __m128 m = _mm_and_ps(inside, _mm_cmple_ps(t0, t1));
    return static_cast<std::uint32_t>(_mm_movemask_ps(m)) & used_mask(n);
#else
    std::uint32_t mask = 0;
    for (std::uint32_t c = 0; c < kWidth; ++c) {
      const Item it = item(n, c);
      mask |= static_cast<std::uint32_t>(ray.hits(it.min, it.max, entry[c])) << c;
    }
    return mask & used_mask(n);
#endif
  }

  void prefetch(std::uint32_t node) const {
    const char* p = reinterpret_cast<const char*>(&nodes_[node]);
    __builtin_prefetch(p);
    __builtin_prefetch(p + 64);
  }

  // The subtree at `root`, recursively (only past kStack levels).
  template <class Hit>
  void walk_overlap(std::uint32_t root, const Aabb& q, Hit& hit) const {
    const Node& n = nodes_[root];
    const std::uint32_t mask = overlap_mask(n, q), objects = object_mask(n);
    for (std::uint32_t m = mask & objects; m; m &= m - 1) report(n, lane(m), hit);
    for (std::uint32_t m = mask & ~objects; m; m &= m - 1) walk_overlap(n.link[lane(m)], q, hit);
  }
  template <class Hit>
  void walk_ray(std::uint32_t root, const RaySegment& ray, const RayLanes& lanes, Hit& hit) const {
    const Node& n = nodes_[root];
    float entry[kWidth];
    const std::uint32_t mask = ray_mask(n, ray, lanes, entry), objects = object_mask(n);
    for (std::uint32_t m = mask & objects; m; m &= m - 1) report_ray(n, lane(m), entry, hit);
    for (std::uint32_t m = mask & ~objects; m; m &= m - 1) walk_ray(n.link[lane(m)], ray, lanes, hit);
  }

  std::vector<Node> nodes_;  // root at 0, a node before its descendants
};

}  // namespace hbp::detail
