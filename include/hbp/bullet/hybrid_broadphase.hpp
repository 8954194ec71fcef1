#pragma once
// Drop-in Bullet 2 broad phase backed by hbp::HybridBroadPhase (k-d partition,
// cell engine, de-duplication). One line switches a Bullet world to it:
//
//   hbp::bullet::HybridBroadphase broadphase;        // instead of btDbvtBroadphase
//   btDiscreteDynamicsWorld world(&dispatcher, &broadphase, &solver, &config);
//
// Semantics, stated where they differ from btDbvtBroadphase:
// - Pairs are exact: the overlapping pair cache holds exactly the proxies whose
//   AABBs overlap under the closed-interval float32 rule (touching faces
//   collide) and that the cache's filter accepts (group/mask or a
//   btOverlapFilterCallback, checked by addOverlappingPair when a pair
//   appears). No fattened boxes, no stale pairs.
// - Pairs are computed in calculateOverlappingPairs(), not in createProxy() or
//   setAabb(): the frame's pair set is diffed against the previous frame's and
//   only the difference goes to the cache (addOverlappingPair for new pairs,
//   removeOverlappingPair for pairs that separated), so persisting pairs keep
//   their collision algorithm and contact manifold.
// - A filter change on a live proxy applies to pairs that appear afterwards;
//   btCollisionWorld::refreshBroadphaseProxy() (destroy + create) re-filters.
// - aabbTest() and rayTest() scan every live proxy's exact AABB (a linear scan
//   over the structure-of-arrays boxes, not the partition): the answer is
//   exactly what a brute-force box/box or ray/box test returns; rayTest uses
//   Bullet's own slab test (btRayAabb2) on the exact box grown by the query
//   box, so it is a subset of btDbvtBroadphase's answer on the same boxes.
// - Invalid AABBs (NaN, infinite, min > max) make calculateOverlappingPairs()
//   throw hbp::InvalidInput naming the dense object index.
#include <cstdint>
#include <memory>

#include "hbp/hybrid_broadphase.hpp"

#pragma GCC diagnostic push
#pragma GCC diagnostic ignored "-Wunused-parameter"
#pragma GCC diagnostic ignored "-Wdeprecated-copy"
#pragma GCC diagnostic ignored "-Wunused-variable"
#pragma GCC diagnostic ignored "-Wunused-but-set-variable"
#pragma GCC diagnostic ignored "-Wclass-memaccess"
#pragma GCC diagnostic ignored "-Wmaybe-uninitialized"
#include <BulletCollision/BroadphaseCollision/btBroadphaseInterface.h>
#include <BulletCollision/BroadphaseCollision/btBroadphaseProxy.h>
#include <BulletCollision/BroadphaseCollision/btOverlappingPairCache.h>
#pragma GCC diagnostic pop

namespace hbp::bullet {

// Counters since construction (or the last resetPool() on an empty pool).
struct BroadphaseCounters {
  std::uint64_t frames = 0;           // calculateOverlappingPairs() calls
  std::uint64_t proxies_created = 0;
  std::uint64_t proxies_destroyed = 0;
  std::uint64_t pairs_added = 0;      // offered to addOverlappingPair()
  std::uint64_t pairs_removed = 0;    // given to removeOverlappingPair()
  std::uint64_t last_pairs = 0;       // exact pairs found by the last frame
  std::uint64_t last_added = 0, last_removed = 0;
  double last_ms = 0;                 // wall time of the last frame
  double total_ms = 0;
};

class HybridBroadphase final : public btBroadphaseInterface {
 public:
  // `cache`: an overlapping pair cache to fill (not owned), or nullptr for an
  // owned btHashedOverlappingPairCache, as btDbvtBroadphase does.
  // `options`: the hybrid system's options; `sorted` is forced on (the
  // incremental diff merges two sorted pair lists).
  explicit HybridBroadphase(btOverlappingPairCache* cache = nullptr, const BroadPhaseOptions& options = {});
  explicit HybridBroadphase(const BroadPhaseOptions& options) : HybridBroadphase(nullptr, options) {}
  ~HybridBroadphase() override;
  HybridBroadphase(const HybridBroadphase&) = delete;
  HybridBroadphase& operator=(const HybridBroadphase&) = delete;

  btBroadphaseProxy* createProxy(const btVector3& aabbMin, const btVector3& aabbMax, int shapeType, void* userPtr,
                                 int collisionFilterGroup, int collisionFilterMask, btDispatcher* dispatcher) override;
  // Removes the proxy's pairs from the cache at once.
  void destroyProxy(btBroadphaseProxy* proxy, btDispatcher* dispatcher) override;
  // Stores the box; pairs change at the next calculateOverlappingPairs().
  void setAabb(btBroadphaseProxy* proxy, const btVector3& aabbMin, const btVector3& aabbMax,
               btDispatcher* dispatcher) override;
  void getAabb(btBroadphaseProxy* proxy, btVector3& aabbMin, btVector3& aabbMax) const override;

  // Every live proxy whose exact AABB, grown by the query box (min - aabbMax,
  // max - aabbMin, as btDbvtBroadphase does), passes btRayAabb2 with the
  // callback's m_rayDirectionInverse, m_signs and m_lambda_max (read once, at
  // the start). Linear scan; hits are collected first, then process() is
  // called for each in dense-index order.
  void rayTest(const btVector3& rayFrom, const btVector3& rayTo, btBroadphaseRayCallback& rayCallback,
               const btVector3& aabbMin = btVector3(0, 0, 0),
               const btVector3& aabbMax = btVector3(0, 0, 0)) override;
  // Every live proxy whose exact AABB overlaps [aabbMin, aabbMax] (closed
  // intervals). Linear scan; process() called in dense-index order.
  void aabbTest(const btVector3& aabbMin, const btVector3& aabbMax, btBroadphaseAabbCallback& callback) override;

  // One frame of the hybrid system over the live proxies' boxes, then the
  // incremental update of the pair cache.
  void calculateOverlappingPairs(btDispatcher* dispatcher) override;

  btOverlappingPairCache* getOverlappingPairCache() override;
  const btOverlappingPairCache* getOverlappingPairCache() const override;

  // The union of the live proxies' exact AABBs; a zero box when there are none.
  void getBroadphaseAabb(btVector3& aabbMin, btVector3& aabbMax) const override;

  // With no live proxies: drops the partition and restarts proxy ids, so a
  // rebuilt world gets the same ids and pair order (determinism). Otherwise
  // does nothing (as btDbvtBroadphase).
  void resetPool(btDispatcher* dispatcher) override;

  // Proxies, pairs, cells and timings of the last frame, to stdout.
  void printStats() override;

  // Not part of Bullet's interface.
  std::size_t proxy_count() const;
  const BroadphaseCounters& counters() const;
  const FrameStats& frame_stats() const;  // the hybrid system's last frame
  const BroadPhaseOptions& options() const;

 private:
  struct Impl;
  std::unique_ptr<Impl> impl_;
};

}  // namespace hbp::bullet
