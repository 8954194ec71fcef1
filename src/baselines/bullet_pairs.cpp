// SPDX-License-Identifier: MIT
#include "baselines/bullet_pairs.hpp"

#include "hbp/bullet/bullet_headers.hpp"

namespace hbp::baselines {

void* bullet_user_pointer(std::uint32_t index) {
  // Offset by one so object 0 is not a null pointer.
  return reinterpret_cast<void*>(static_cast<std::uintptr_t>(index) + 1);
}

std::uint32_t bullet_object_index(const void* user_pointer) {
  return static_cast<std::uint32_t>(reinterpret_cast<std::uintptr_t>(user_pointer) - 1);
}

btVector3 bullet_min(const BoxArray& boxes, std::size_t i) {
  return {boxes.min(0)[i], boxes.min(1)[i], boxes.min(2)[i]};
}

btVector3 bullet_max(const BoxArray& boxes, std::size_t i) {
  return {boxes.max(0)[i], boxes.max(1)[i], boxes.max(2)[i]};
}

std::size_t exact_bullet_pairs(btOverlappingPairCache& cache, const BoxArray& boxes, std::vector<Pair>& out) {
  out.clear();
  const btBroadphasePairArray& raw = cache.getOverlappingPairArray();
  const int count = raw.size();
  for (int k = 0; k < count; ++k) {
    const btBroadphasePair& p = raw[k];
    const std::uint32_t a = bullet_object_index(p.m_pProxy0->m_clientObject);
    const std::uint32_t b = bullet_object_index(p.m_pProxy1->m_clientObject);
    if (overlaps(boxes.get(a), boxes.get(b))) out.push_back(make_pair(a, b));
  }
  // Bullet's cache holds each pair once; sort into the canonical order.
  canonicalize(out);
  return static_cast<std::size_t>(count);
}

void BulletProxies::create(btBroadphaseInterface& broadphase, const BoxArray& boxes) {
  const auto n = static_cast<std::uint32_t>(boxes.size());
  proxies_.resize(n);
  // Any convex shape type: the broad phase only uses it to tell static or
  // soft bodies apart.
  for (std::uint32_t i = 0; i < n; ++i) {
    proxies_[i] = broadphase.createProxy(bullet_min(boxes, i), bullet_max(boxes, i), BOX_SHAPE_PROXYTYPE,
                                         bullet_user_pointer(i), btBroadphaseProxy::DefaultFilter,
                                         btBroadphaseProxy::AllFilter, nullptr);
  }
  broadphase.calculateOverlappingPairs(nullptr);
  boxes_ = &boxes;
  dirty_ = true;
}

void BulletProxies::update(btBroadphaseInterface& broadphase, const BoxArray& boxes) {
  const std::size_t n = proxies_.size();
  for (std::size_t i = 0; i < n; ++i) broadphase.setAabb(proxies_[i], bullet_min(boxes, i), bullet_max(boxes, i), nullptr);
  broadphase.calculateOverlappingPairs(nullptr);
  boxes_ = &boxes;
  dirty_ = true;
}

std::size_t BulletProxies::raw_pairs(const btBroadphaseInterface* broadphase) const {
  return broadphase ? static_cast<std::size_t>(broadphase->getOverlappingPairCache()->getNumOverlappingPairs()) : 0;
}

const std::vector<Pair>& BulletProxies::exact_pairs(btBroadphaseInterface* broadphase) {
  if (dirty_ && broadphase && boxes_) {
    exact_bullet_pairs(*broadphase->getOverlappingPairCache(), *boxes_, exact_);
    dirty_ = false;
  }
  return exact_;
}

void BulletProxies::clear() {
  proxies_.clear();
  exact_.clear();
  boxes_ = nullptr;
  dirty_ = false;
}

}  // namespace hbp::baselines
