#pragma once
// A flat BVH over a BoxArray (binned SAH, one box per leaf, depth-first
// pre-order; partition/cell_bvh), answering exact closed box and ray queries
// with the indices of the boxes. BroadPhase keeps one over its static objects
// (built when statics change) and one over its moving objects (built lazily
// for queries, refitted while the membership does not change).
#include <cstdint>
#include <utility>
#include <vector>

#include "hbp/aabb.hpp"
#include "hbp/box_array.hpp"
#include "hbp/two_level_hierarchy.hpp"
#include "pipeline/ray_segment.hpp"

namespace hbp::detail {

class BoxTree {
 public:
  // Rebuilds over every box of `boxes` (leaf object = box index).
  void build(const BoxArray& boxes);
  // Same membership, new boxes.
  void refit(const BoxArray& boxes);
  void clear();
  bool empty() const { return nodes_.empty(); }
  std::size_t leaves() const { return (nodes_.size() + 1) / 2; }

  // Calls hit(index) for every box overlapping the closed box q.
  template <class Hit>
  void for_each_overlap(const Aabb& q, Hit&& hit) const {
    if (nodes_.empty()) return;
    thread_local std::vector<std::uint32_t> stack;
    stack.clear();
    std::uint32_t i = 0;
    for (;;) {
      const BvhNode& n = nodes_[i];
      const bool in = n.max[0] >= q.min[0] && n.min[0] <= q.max[0] && n.max[1] >= q.min[1] &&
                      n.min[1] <= q.max[1] && n.max[2] >= q.min[2] && n.min[2] <= q.max[2];
      if (in) {
        if (n.leaf()) {
          hit(n.object);
        } else {
          stack.push_back(n.right);
          i = i + 1;
          continue;
        }
      }
      if (stack.empty()) return;
      i = stack.back();
      stack.pop_back();
    }
  }

  // Calls hit(index, entry_t) for every box the segment touches.
  template <class Hit>
  void for_each_ray_hit(const RaySegment& ray, Hit&& hit) const {
    if (nodes_.empty()) return;
    thread_local std::vector<std::uint32_t> stack;
    stack.clear();
    std::uint32_t i = 0;
    for (;;) {
      const BvhNode& n = nodes_[i];
      float t;
      if (ray.hits(n.min, n.max, t)) {
        if (n.leaf()) {
          hit(n.object, t);
        } else {
          stack.push_back(n.right);
          i = i + 1;
          continue;
        }
      }
      if (stack.empty()) return;
      i = stack.back();
      stack.pop_back();
    }
  }

  std::size_t memory_bytes() const { return nodes_.capacity() * sizeof(BvhNode); }

 private:
  std::vector<BvhNode> nodes_;
};

}  // namespace hbp::detail
