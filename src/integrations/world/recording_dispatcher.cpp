// SPDX-License-Identifier: MIT
#include "integrations/world/recording_dispatcher.hpp"

#include "hbp/aabb.hpp"

namespace hbp::bullet::world {
namespace {

Aabb box_of(const btBroadphaseProxy* p) {
  return {{p->m_aabbMin.getX(), p->m_aabbMin.getY(), p->m_aabbMin.getZ()},
          {p->m_aabbMax.getX(), p->m_aabbMax.getY(), p->m_aabbMax.getZ()}};
}

std::uint32_t index_of(const btBroadphaseProxy* p) {
  return static_cast<std::uint32_t>(static_cast<const btCollisionObject*>(p->m_clientObject)->getUserIndex());
}

}  // namespace

void RecordingDispatcher::dispatchAllCollisionPairs(btOverlappingPairCache* cache, const btDispatcherInfo& info,
                                                    btDispatcher* dispatcher) {
  if (recording_) {
    const int n = cache->getNumOverlappingPairs();
    const btBroadphasePair* pairs = cache->getOverlappingPairArrayPtr();
    last_.raw = static_cast<std::size_t>(n);
    last_.exact.clear();
    for (int i = 0; i < n; ++i) {
      const btBroadphaseProxy* a = pairs[i].m_pProxy0;
      const btBroadphaseProxy* b = pairs[i].m_pProxy1;
      if (overlaps(box_of(a), box_of(b))) last_.exact.push_back(make_pair(index_of(a), index_of(b)));
    }
    last_.duplicates = canonicalize(last_.exact);
  }
  btCollisionDispatcher::dispatchAllCollisionPairs(cache, info, dispatcher);
}

}  // namespace hbp::bullet::world
