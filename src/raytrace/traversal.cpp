// SPDX-License-Identifier: MIT
#include "hbp/raytrace/traversal.hpp"

#include <cmath>
#include <utility>
#include <vector>

namespace hbp {

namespace {

// The ray as the box tests use it.
struct RayBoxes {
  double o[3];
  double inv[3];  // 1 / dir (infinite for a zero component)
  explicit RayBoxes(const Ray& r) {
    for (int k = 0; k < 3; ++k) {
      o[k] = r.origin[k];
      inv[k] = 1.0 / r.dir[k];
    }
  }
};

// Slab test against a closed box. The far distances (and tmax, so a shape
// hit at exactly the current closest distance still counts: ties go to the
// lower id) are widened by a few ulps so a shape hit on the box's surface is
// never culled by rounding. NaN (a ray in a slab's plane, parallel to it)
// leaves the interval unchanged: closed.
inline bool slab(const float* mn, const float* mx, const RayBoxes& r, double tmin, double tmax, double& t_near) {
  double t0 = tmin, t1 = tmax * (1 + 1e-12);
  for (int k = 0; k < 3; ++k) {
    double a = (mn[k] - r.o[k]) * r.inv[k];
    double b = (mx[k] - r.o[k]) * r.inv[k];
    if (a > b) std::swap(a, b);
    t0 = a > t0 ? a : t0;
    t1 = b * (1 + 1e-12) < t1 ? b * (1 + 1e-12) : t1;
  }
  t_near = t0;
  return t0 <= t1;
}

template <bool kAny>
bool traverse_bvh(std::span<const BvhNode> nodes, std::span<const ShapeGeometry> geometry, const Ray& ray,
                  const RayBoxes& rb, RayHit& best, std::vector<std::uint32_t>& stack) {
  if (nodes.empty()) return false;
  double tn;
  if (!slab(nodes[0].min, nodes[0].max, rb, ray.tmin, best.t, tn)) return false;
  const std::size_t base = stack.size();
  std::uint32_t i = 0;
  for (;;) {
    const BvhNode& n = nodes[i];
    if (n.leaf()) {
      double t;
      std::uint8_t part;
      if (intersect_ray(geometry[n.object], ray, ray.tmin, best.t, t, part) && closer(t, n.object, best)) {
        best.t = t;
        best.object = n.object;
        best.part = part;
        if (kAny) {
          stack.resize(base);
          return true;
        }
      }
    } else {
      std::uint32_t a = i + 1, b = n.right;
      double ta, tb;
      const bool ha = slab(nodes[a].min, nodes[a].max, rb, ray.tmin, best.t, ta);
      const bool hb = slab(nodes[b].min, nodes[b].max, rb, ray.tmin, best.t, tb);
      if (ha && hb) {
        if (tb < ta) std::swap(a, b);
        stack.push_back(b);
        i = a;
        continue;
      }
      if (ha || hb) {
        i = ha ? a : b;
        continue;
      }
    }
    if (stack.size() == base) return best.hit();
    i = stack.back();
    stack.pop_back();
  }
}

struct KdItem {
  std::uint32_t node;
  double t0, t1;
};

thread_local std::vector<std::uint32_t> t_bvh_stack;
thread_local std::vector<KdItem> t_kd_stack;

template <bool kAny>
RayHit traverse(const TwoLevelHierarchy& h, std::span<const ShapeGeometry> geometry, const Ray& ray) {
  RayHit best;
  best.t = ray.tmax;
  const RayBoxes rb(ray);
  double t0, t1;
  {
    double tn;
    if (h.cell_count() == 0 || !slab(h.bounds().min, h.bounds().max, rb, ray.tmin, ray.tmax, tn)) return best;
    t0 = tn;
    t1 = ray.tmax;
    // Exit distance of the scene box, for the cells' intervals.
    for (int k = 0; k < 3; ++k) {
      const double a = (h.bounds().min[k] - rb.o[k]) * rb.inv[k], b = (h.bounds().max[k] - rb.o[k]) * rb.inv[k];
      const double far = a > b ? a : b;
      if (far == far && far * (1 + 1e-12) < t1) t1 = far * (1 + 1e-12);
    }
  }
  const std::span<const KdNode> nodes = h.kd_nodes();
  std::vector<std::uint32_t>& bvh_stack = t_bvh_stack;
  std::vector<KdItem>& stack = t_kd_stack;
  stack.clear();
  std::uint32_t node = 0;
  for (;;) {
    while (nodes[node].axis >= 0) {
      const KdNode& n = nodes[node];
      const int a = n.axis;
      const double o = ray.origin[a], d = ray.dir[a], s = n.split;
      // Half-open regions: a point on the plane belongs above it.
      const bool below = o < s || (o == s && d < 0);
      const std::uint32_t near = below ? n.child : n.child + 1, far = below ? n.child + 1 : n.child;
      if (d == 0) {
        node = near;
        continue;
      }
      const double ts = (s - o) / d;
      if (ts > t1 || ts < 0) {
        node = near;
      } else if (ts < t0) {
        node = far;
      } else {
        stack.push_back({far, ts, t1});
        node = near;
        t1 = ts;
      }
    }
    const bool hit = traverse_bvh<kAny>(h.cell_bvh(nodes[node].cell), geometry, ray, rb, best, bvh_stack);
    if (kAny && hit) return best;
    // Done once the closest hit lies before this cell's exit (a hair of slack
    // for rounding in the cells' intervals).
    if (best.hit() && best.t + 1e-9 * (1 + std::fabs(t1)) < t1) return best;
    if (stack.empty()) return best;
    node = stack.back().node;
    t0 = stack.back().t0;
    t1 = stack.back().t1;
    stack.pop_back();
  }
}

template <bool kAny>
RayHit brute(std::span<const ShapeGeometry> geometry, const Ray& ray) {
  RayHit best;
  best.t = ray.tmax;
  for (std::uint32_t i = 0; i < geometry.size(); ++i) {
    double t;
    std::uint8_t part;
    if (intersect_ray(geometry[i], ray, ray.tmin, best.t, t, part) && closer(t, i, best)) {
      best.t = t;
      best.object = i;
      best.part = part;
      if (kAny) break;
    }
  }
  return best;
}

}  // namespace

RayHit closest_hit(const TwoLevelHierarchy& h, std::span<const ShapeGeometry> geometry, const Ray& ray) {
  return traverse<false>(h, geometry, ray);
}

bool any_hit(const TwoLevelHierarchy& h, std::span<const ShapeGeometry> geometry, const Ray& ray) {
  return traverse<true>(h, geometry, ray).hit();
}

RayHit closest_hit(std::span<const BvhNode> bvh, std::span<const ShapeGeometry> geometry, const Ray& ray) {
  RayHit best;
  best.t = ray.tmax;
  traverse_bvh<false>(bvh, geometry, ray, RayBoxes(ray), best, t_bvh_stack);
  return best;
}

bool any_hit(std::span<const BvhNode> bvh, std::span<const ShapeGeometry> geometry, const Ray& ray) {
  RayHit best;
  best.t = ray.tmax;
  return traverse_bvh<true>(bvh, geometry, ray, RayBoxes(ray), best, t_bvh_stack);
}

RayHit brute_force_closest_hit(std::span<const ShapeGeometry> geometry, const Ray& ray) {
  return brute<false>(geometry, ray);
}

bool brute_force_any_hit(std::span<const ShapeGeometry> geometry, const Ray& ray) {
  return brute<true>(geometry, ray).hit();
}

}  // namespace hbp
