// SPDX-License-Identifier: MIT
#pragma once
// Reading Bullet's pair cache: proxies carry their object index as the user
// pointer; the cache holds a superset of the exact pairs (fattened DBVT
// leaves, quantised sweep-and-prune endpoints), filtered here with the one
// closed-interval overlap rule of the system.
#include <cstdint>
#include <vector>

#include "hbp/box_array.hpp"
#include "hbp/pair.hpp"

class btOverlappingPairCache;
class btVector3;
class btBroadphaseInterface;
struct btBroadphaseProxy;

namespace hbp::baselines {

// The user pointer stored in a proxy for object i, and back.
void* bullet_user_pointer(std::uint32_t index);
std::uint32_t bullet_object_index(const void* user_pointer);

// Bullet's min / max corners of box i (single precision, bit-identical).
btVector3 bullet_min(const BoxArray& boxes, std::size_t i);
btVector3 bullet_max(const BoxArray& boxes, std::size_t i);

// Fills `out` with the cache's pairs whose boxes overlap exactly, sorted and
// canonical; returns the cache's raw pair count.
std::size_t exact_bullet_pairs(btOverlappingPairCache& cache, const BoxArray& boxes, std::vector<Pair>& out);

// What every Bullet baseline does, on any broad phase: proxies created once
// (user pointer = object index), then each frame every AABB set and
// calculateOverlappingPairs, the cache read back exactly on demand.
class BulletProxies {
 public:
  void create(btBroadphaseInterface& broadphase, const BoxArray& boxes);
  void update(btBroadphaseInterface& broadphase, const BoxArray& boxes);
  std::size_t raw_pairs(const btBroadphaseInterface* broadphase) const;
  const std::vector<Pair>& exact_pairs(btBroadphaseInterface* broadphase);
  const std::vector<btBroadphaseProxy*>& proxies() const { return proxies_; }
  void clear();

 private:
  std::vector<btBroadphaseProxy*> proxies_;
  const BoxArray* boxes_ = nullptr;
  std::vector<Pair> exact_;
  bool dirty_ = false;
};

}  // namespace hbp::baselines
