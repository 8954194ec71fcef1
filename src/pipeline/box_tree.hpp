#pragma once
// A flat BVH over a BoxArray answering exact closed box and ray queries with
// the indices of the boxes. BroadPhase keeps one over its static objects
// (built when statics change) and one over its moving objects (built lazily
// for queries, refitted while the membership does not change).
//
// Built by the binned-SAH builder of hierarchy/cell_bvh (one box per leaf),
// then collapsed: every subtree of at most kLeafSize boxes becomes one leaf
// whose boxes are stored contiguously (Item), so a query touches a quarter of
// the nodes and reads the boxes it tests from one cache-friendly run.
#include <cstdint>
#include <utility>
#include <vector>

#include "hbp/aabb.hpp"
#include "hbp/box_array.hpp"
#include "pipeline/ray_segment.hpp"

namespace hbp::detail {

class BoxTree {
 public:
  static constexpr std::uint32_t kLeafSize = 4;

  // A box and its index: the leaves' contents, in tree order.
  struct Item {
    float min[3];
    float max[3];
    std::uint32_t index;
  };
  // count == 0: internal node, children next and `link`; else a leaf of
  // items [link, link + count).
  struct Node {
    float min[3];
    std::uint32_t link;
    float max[3];
    std::uint32_t count;
  };
  static_assert(sizeof(Node) == 32 && sizeof(Item) == 28);

  // Rebuilds over every box of `boxes` (item index = box index).
  void build(const BoxArray& boxes);
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
      if (overlaps(n.min, n.max, q)) {
        if (n.count == 0) {
          if (top == kStack) {  // deeper than any SAH tree of 2^32 boxes: walk the rest recursively
            walk_overlap(n.link, q, hit);
          } else {
            stack[top++] = n.link;
          }
          i = i + 1;
          continue;
        }
        for (std::uint32_t k = n.link; k < n.link + n.count; ++k)
          if (overlaps(items_[k].min, items_[k].max, q)) hit(items_[k].index, items_[k]);
      }
      if (top == 0) return;
      i = stack[--top];
    }
  }

  // Calls hit(index, entry_t) for every box the segment touches.
  template <class Hit>
  void for_each_ray_hit(const RaySegment& ray, Hit&& hit) const {
    if (nodes_.empty()) return;
    std::uint32_t stack[kStack];
    std::uint32_t top = 0;
    std::uint32_t i = 0;
    float t;
    for (;;) {
      const Node& n = nodes_[i];
      if (ray.hits(n.min, n.max, t)) {
        if (n.count == 0) {
          if (top == kStack) {
            walk_ray(n.link, ray, hit);
          } else {
            stack[top++] = n.link;
          }
          i = i + 1;
          continue;
        }
        for (std::uint32_t k = n.link; k < n.link + n.count; ++k)
          if (ray.hits(items_[k].min, items_[k].max, t)) hit(items_[k].index, t);
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

  // The subtree at `root`, recursively (only past kStack levels).
  template <class Hit>
  void walk_overlap(std::uint32_t root, const Aabb& q, Hit& hit) const {
    const Node& n = nodes_[root];
    if (!overlaps(n.min, n.max, q)) return;
    if (n.count == 0) {
      walk_overlap(root + 1, q, hit);
      walk_overlap(n.link, q, hit);
      return;
    }
    for (std::uint32_t k = n.link; k < n.link + n.count; ++k)
      if (overlaps(items_[k].min, items_[k].max, q)) hit(items_[k].index, items_[k]);
  }
  template <class Hit>
  void walk_ray(std::uint32_t root, const RaySegment& ray, Hit& hit) const {
    const Node& n = nodes_[root];
    float t;
    if (!ray.hits(n.min, n.max, t)) return;
    if (n.count == 0) {
      walk_ray(root + 1, ray, hit);
      walk_ray(n.link, ray, hit);
      return;
    }
    for (std::uint32_t k = n.link; k < n.link + n.count; ++k)
      if (ray.hits(items_[k].min, items_[k].max, t)) hit(items_[k].index, t);
  }

  std::vector<Node> nodes_;
  std::vector<Item> items_;
};

}  // namespace hbp::detail
