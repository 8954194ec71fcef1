// SPDX-License-Identifier: MIT
#pragma once
// Drop-in Bullet 2 broad phase backed by hbp::HybridBroadPhase (k-d partition,
// cell engine, de-duplication). Named for what it is, hbp::BroadPhase adapted
// to Bullet's btBroadphaseInterface (not a second hybrid system). One line
// switches a Bullet world to it:
//
//   hbp::bullet::BroadphaseAdapter broadphase;        // instead of btDbvtBroadphase
//   btDiscreteDynamicsWorld world(&dispatcher, &broadphase, &solver, &config);
//
// Built on hbp::BroadPhase (broad_phase.hpp): each proxy is a handle, the
// pair cache is fed the frame's created and removed pairs, and the queries
// are BroadPhase's tree queries. Semantics, stated where they differ from
// btDbvtBroadphase:
// - Pairs are exact: the overlapping pair cache holds exactly the proxies whose
//   AABBs overlap under the closed-interval float32 rule (touching faces
//   collide) and that the cache's filter accepts (group/mask or a
//   btOverlapFilterCallback, checked by addOverlappingPair when a pair
//   appears). No fattened boxes, no stale pairs.
// - Pairs are computed in calculateOverlappingPairs(), not in createProxy() or
//   setAabb(): only the frame's created pairs (addOverlappingPair) and removed
//   pairs (removeOverlappingPair) go to the cache, so persisting pairs keep
//   their collision algorithm and contact manifold.
// - Static proxies (collision filter group exactly StaticFilter, mask without
//   StaticFilter, and no btOverlapFilterCallback on the cache at creation:
//   Bullet's own filter would reject every pair of two of them) are
//   BroadPhase static objects: they cost nothing per frame while they stay
//   put (a setAabb with the same box is not a move).
// - A filter change on a live proxy applies to pairs that appear afterwards;
//   btCollisionWorld::refreshBroadphaseProxy() (destroy + create) re-filters.
// - aabbTest(): BroadPhase::query_box, exact closed boxes; process() called in
//   handle order. rayTest(): the proxies whose exact AABB, grown by the query
//   box (min - aabbMax, max - aabbMin, as btDbvtBroadphase does), passes
//   Bullet's own slab test btRayAabb2 with the callback's
//   m_rayDirectionInverse, m_signs and m_lambda_max (read once, at the start);
//   candidates come from query_box over the swept segment's bounds. A subset
//   of btDbvtBroadphase's answer on the same boxes.
// - Stale proxies are caught: setAabb, getAabb or destroyProxy on a destroyed
//   proxy throws hbp::InvalidInput (a destroyed proxy's memory is kept, marked
//   dead, until at least max(1024, live proxies) later proxies were destroyed,
//   and its handle's generation no longer matches its slot's).
// - Invalid AABBs (NaN, infinite, min > max) make createProxy() / setAabb()
//   throw hbp::InvalidInput naming the proxy; nothing is changed.
#include <cstdint>
#include <memory>

#include "hbp/broad_phase.hpp"

#include "hbp/bullet/bullet_headers.hpp"

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

class BroadphaseAdapter final : public btBroadphaseInterface {
 public:
  // `cache`: an overlapping pair cache to fill (not owned), or nullptr for an
  // owned btHashedOverlappingPairCache, as btDbvtBroadphase does.
  // `options`: the hybrid system's options (BroadPhase; `sorted` is ignored).
  explicit BroadphaseAdapter(btOverlappingPairCache* cache = nullptr, const BroadPhaseOptions& options = {});
  explicit BroadphaseAdapter(const BroadPhaseOptions& options) : BroadphaseAdapter(nullptr, options) {}
  ~BroadphaseAdapter() override;
  BroadphaseAdapter(const BroadphaseAdapter&) = delete;
  BroadphaseAdapter& operator=(const BroadphaseAdapter&) = delete;

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
  // the start). Hits are collected first, then process() is called for each
  // in handle order.
  void rayTest(const btVector3& rayFrom, const btVector3& rayTo, btBroadphaseRayCallback& rayCallback,
               const btVector3& aabbMin = btVector3(0, 0, 0),
               const btVector3& aabbMax = btVector3(0, 0, 0)) override;
  // Every live proxy whose exact AABB overlaps [aabbMin, aabbMax] (closed
  // intervals); process() called in handle order.
  void aabbTest(const btVector3& aabbMin, const btVector3& aabbMax, btBroadphaseAabbCallback& callback) override;

  // BroadPhase::update(), then its created / removed pairs to the cache.
  void calculateOverlappingPairs(btDispatcher* dispatcher) override;

  btOverlappingPairCache* getOverlappingPairCache() override;
  const btOverlappingPairCache* getOverlappingPairCache() const override;

  // The union of the live proxies' exact AABBs; a zero box when there are none.
  void getBroadphaseAabb(btVector3& aabbMin, btVector3& aabbMax) const override;

  // With no live proxies: starts a fresh BroadPhase and restarts proxy ids, so
  // a rebuilt world gets the same ids and pair order (determinism). Otherwise
  // does nothing (as btDbvtBroadphase).
  void resetPool(btDispatcher* dispatcher) override;

  // Proxies, pairs and timings of the last frame, to stdout.
  void printStats() override;

  // Not part of Bullet's interface.
  std::size_t proxy_count() const;
  const BroadphaseCounters& counters() const;
  const BroadPhaseUpdateStats& frame_stats() const;  // BroadPhase's last update
  const BroadPhase& broad_phase() const;
  const BroadPhaseOptions& options() const;

 private:
  struct Impl;
  std::unique_ptr<Impl> impl_;
};

}  // namespace hbp::bullet
