// SPDX-License-Identifier: MIT
// hbp::bullet::BroadphaseAdapter: Bullet's btBroadphaseInterface over
// hbp::BroadPhase.
//
// Each proxy holds its BroadPhase handle; by_slot maps a handle's slot back to
// the proxy. calculateOverlappingPairs() hands BroadPhase's created pairs to
// addOverlappingPair and its removed pairs to removeOverlappingPair (pairs of
// destroyed proxies left the cache at destroyProxy()).
//
// Stale proxies: destroyProxy() marks the proxy dead and keeps its memory in
// a FIFO quarantine, recycled only once the quarantine holds more than
// max(1024, live proxies); until then setAabb / getAabb / destroyProxy on it
// throw instead of reading freed memory or touching the proxy now in its slot.
#include "hbp/bullet/broadphase_adapter.hpp"

#include <algorithm>
#include <chrono>
#include <cmath>
#include <cstdio>
#include <deque>
#include <string>
#include <vector>

#include "hbp/bullet/bullet_headers.hpp"

#include "hbp/error.hpp"
#include "hbp/pair.hpp"

namespace hbp::bullet {

static_assert(sizeof(btScalar) == sizeof(float),
              "hbp::bullet::BroadphaseAdapter needs single-precision Bullet (the boxes are float32)");

namespace {

constexpr std::uint32_t kSlotMask = (1u << kHandleSlotBits) - 1;
constexpr std::size_t kMinQuarantine = 1024;

// A Bullet proxy that knows its BroadPhase handle and whether it is alive.
struct Proxy : btBroadphaseProxy {
  Handle handle = kInvalidHandle;
  bool alive = false;
};

Proxy* as_proxy(btBroadphaseProxy* p) { return static_cast<Proxy*>(p); }

Aabb to_box(const btVector3& lo, const btVector3& hi) {
  return {{lo.getX(), lo.getY(), lo.getZ()}, {hi.getX(), hi.getY(), hi.getZ()}};
}

bool same_box(const btVector3& a_lo, const btVector3& a_hi, const btVector3& b_lo, const btVector3& b_hi) {
  for (int k = 0; k < 3; ++k)
    if (a_lo[k] != b_lo[k] || a_hi[k] != b_hi[k]) return false;
  return true;
}

}  // namespace

struct BroadphaseAdapter::Impl {
  explicit Impl(btOverlappingPairCache* external, const BroadPhaseOptions& opts) : options(opts), bp(checked(options)) {
    if (external) {
      cache = external;
    } else {
      owned_cache = std::make_unique<btHashedOverlappingPairCache>();
      cache = owned_cache.get();
    }
  }

  ~Impl() {
    for (Proxy* p : by_slot) delete p;
    for (Proxy* p : quarantine) delete p;
  }

  // The live proxy `p` points to, or throws naming the call.
  Proxy* live(btBroadphaseProxy* proxy, const char* call) const {
    Proxy* p = as_proxy(proxy);
    if (p == nullptr || !p->alive || !bp.contains(p->handle)) {
      throw InvalidInput(std::string("hbp::bullet::BroadphaseAdapter::") + call +
                         ": the proxy was destroyed (stale proxy" +
                         (p ? ", unique id " + std::to_string(p->m_uniqueId) : std::string()) + ")");
    }
    return p;
  }

  Proxy* proxy_of(Handle h) const { return by_slot[h & kSlotMask]; }

  Proxy* new_proxy() {
    if (quarantine.size() > std::max(kMinQuarantine, bp.size())) {
      Proxy* p = quarantine.front();
      quarantine.pop_front();
      *p = Proxy();
      return p;
    }
    return new Proxy();
  }

  // The adapter passes float boxes (Aabb): it has no double path.
  static const BroadPhaseOptions& checked(const BroadPhaseOptions& o) {
    if (o.double_precision)
      throw InvalidInput("bullet::BroadphaseAdapter: double_precision is BroadPhase's alone (the adapter passes float boxes)");
    return o;
  }

  BroadPhaseOptions options;
  BroadPhase bp;
  std::unique_ptr<btHashedOverlappingPairCache> owned_cache;
  btOverlappingPairCache* cache = nullptr;
  std::vector<Proxy*> by_slot;     // handle slot -> live proxy (nullptr when free)
  std::deque<Proxy*> quarantine;   // destroyed proxies, oldest first
  BroadphaseCounters counters;
};

BroadphaseAdapter::BroadphaseAdapter(btOverlappingPairCache* cache, const BroadPhaseOptions& options)
    : impl_(std::make_unique<Impl>(cache, options)) {}

BroadphaseAdapter::~BroadphaseAdapter() = default;

btBroadphaseProxy* BroadphaseAdapter::createProxy(const btVector3& aabbMin, const btVector3& aabbMax, int /*shapeType*/,
                                                 void* userPtr, int collisionFilterGroup, int collisionFilterMask,
                                                 btDispatcher* /*dispatcher*/) {
  Impl& s = *impl_;
  // Static when Bullet's own filter rejects every pair of two such proxies.
  const bool is_static = collisionFilterGroup == btBroadphaseProxy::StaticFilter &&
                         (collisionFilterMask & btBroadphaseProxy::StaticFilter) == 0 &&
                         s.cache->getOverlapFilterCallback() == nullptr;
  const Aabb box = to_box(aabbMin, aabbMax);
  Handle h;
  try {
    h = s.bp.add(std::span<const Aabb>(&box, 1), {.is_static = is_static})[0];
  } catch (const InvalidInput& e) {
    throw InvalidInput(std::string("hbp::bullet::BroadphaseAdapter::createProxy: ") + e.what());
  }
  Proxy* p = s.new_proxy();
  p->m_clientObject = userPtr;
  p->m_collisionFilterGroup = collisionFilterGroup;
  p->m_collisionFilterMask = collisionFilterMask;
  p->m_aabbMin = aabbMin;
  p->m_aabbMax = aabbMax;
  p->handle = h;
  p->alive = true;
  const std::uint32_t slot = h & kSlotMask;
  p->m_uniqueId = static_cast<int>(slot) + 1;
  if (slot >= s.by_slot.size()) s.by_slot.resize(slot + 1, nullptr);
  s.by_slot[slot] = p;
  ++s.counters.proxies_created;
  return p;
}

void BroadphaseAdapter::destroyProxy(btBroadphaseProxy* proxy, btDispatcher* dispatcher) {
  Impl& s = *impl_;
  Proxy* p = s.live(proxy, "destroyProxy");
  s.cache->removeOverlappingPairsContainingProxy(p, dispatcher);
  s.bp.remove(std::span<const Handle>(&p->handle, 1));
  s.by_slot[p->handle & kSlotMask] = nullptr;
  p->alive = false;
  s.quarantine.push_back(p);
  ++s.counters.proxies_destroyed;
}

void BroadphaseAdapter::setAabb(btBroadphaseProxy* proxy, const btVector3& aabbMin, const btVector3& aabbMax,
                               btDispatcher* /*dispatcher*/) {
  Impl& s = *impl_;
  Proxy* p = s.live(proxy, "setAabb");
  // Bullet sets every object's box every step (static ones too): an
  // unchanged box is not a move.
  if (same_box(p->m_aabbMin, p->m_aabbMax, aabbMin, aabbMax)) return;
  const Aabb box = to_box(aabbMin, aabbMax);
  try {
    s.bp.move(std::span<const Handle>(&p->handle, 1), std::span<const Aabb>(&box, 1));
  } catch (const InvalidInput& e) {
    throw InvalidInput("hbp::bullet::BroadphaseAdapter::setAabb: proxy with unique id " +
                       std::to_string(p->m_uniqueId) + ": " + e.what());
  }
  p->m_aabbMin = aabbMin;
  p->m_aabbMax = aabbMax;
}

void BroadphaseAdapter::getAabb(btBroadphaseProxy* proxy, btVector3& aabbMin, btVector3& aabbMax) const {
  const Proxy* p = impl_->live(proxy, "getAabb");
  aabbMin = p->m_aabbMin;
  aabbMax = p->m_aabbMax;
}

void BroadphaseAdapter::rayTest(const btVector3& rayFrom, const btVector3& /*rayTo*/,
                               btBroadphaseRayCallback& rayCallback, const btVector3& aabbMin,
                               const btVector3& aabbMax) {
  Impl& s = *impl_;
  const btScalar lambda_max = rayCallback.m_lambda_max;
  const btVector3 inverse = rayCallback.m_rayDirectionInverse;
  const unsigned int signs[3] = {rayCallback.m_signs[0], rayCallback.m_signs[1], rayCallback.m_signs[2]};
  // btRayAabb2 accepts a grown box when the segment rayFrom + t / inverse,
  // 0 <= t <= lambda_max, touches it; every such proxy's box overlaps the
  // segment's bounds grown by the query box, padded for rounding.
  Aabb bounds;
  for (int k = 0; k < 3; ++k) {
    const double d = std::isinf(inverse[k]) || inverse[k] == 0 ? 0.0 : 1.0 / static_cast<double>(inverse[k]);
    const double a = rayFrom[k];
    const double b = a + static_cast<double>(lambda_max) * d;
    const double pad = 1e-5 * (std::fabs(a) + std::fabs(b) + 1.0);
    bounds.min[k] = static_cast<float>(std::min(a, b) + aabbMin[k] - pad);
    bounds.max[k] = static_cast<float>(std::max(a, b) + aabbMax[k] + pad);
  }
  std::vector<Proxy*> proxies;
  if (!box_defect(bounds)) {
    for (const Handle h : s.bp.query_box(bounds)) {
      Proxy* p = s.proxy_of(h);
      const btVector3 grown[2] = {p->m_aabbMin - aabbMax, p->m_aabbMax - aabbMin};
      btScalar tmin;
      if (btRayAabb2(rayFrom, inverse, signs, grown, tmin, 0, lambda_max)) proxies.push_back(p);
    }
  } else {
    // Bounds past float range (a ray to infinity): test every live proxy.
    for (Proxy* p : s.by_slot) {
      if (!p) continue;
      const btVector3 grown[2] = {p->m_aabbMin - aabbMax, p->m_aabbMax - aabbMin};
      btScalar tmin;
      if (btRayAabb2(rayFrom, inverse, signs, grown, tmin, 0, lambda_max)) proxies.push_back(p);
    }
  }
  // Hits first, callbacks after: process() may query this broad phase again.
  for (Proxy* p : proxies) rayCallback.process(p);
}

void BroadphaseAdapter::aabbTest(const btVector3& aabbMin, const btVector3& aabbMax,
                                btBroadphaseAabbCallback& callback) {
  Impl& s = *impl_;
  const std::vector<Handle> hits = s.bp.query_box(to_box(aabbMin, aabbMax));
  for (const Handle h : hits) callback.process(s.proxy_of(h));
}

void BroadphaseAdapter::calculateOverlappingPairs(btDispatcher* dispatcher) {
  Impl& s = *impl_;
  const auto start = std::chrono::steady_clock::now();
  const BroadPhaseUpdate& u = s.bp.update();
  std::uint64_t removed = 0;
  for (const Pair& p : u.removed) {
    // A destroyed proxy's pairs left the cache at destroyProxy().
    if (!s.bp.contains(p.a) || !s.bp.contains(p.b)) continue;
    s.cache->removeOverlappingPair(s.proxy_of(p.a), s.proxy_of(p.b), dispatcher);
    ++removed;
  }
  for (const Pair& p : u.created) s.cache->addOverlappingPair(s.proxy_of(p.a), s.proxy_of(p.b));

  BroadphaseCounters& c = s.counters;
  ++c.frames;
  c.pairs_added += u.created.size();
  c.pairs_removed += removed;
  c.last_added = u.created.size();
  c.last_removed = removed;
  c.last_pairs = u.pairs.size();
  c.last_ms = std::chrono::duration<double, std::milli>(std::chrono::steady_clock::now() - start).count();
  c.total_ms += c.last_ms;
}

btOverlappingPairCache* BroadphaseAdapter::getOverlappingPairCache() { return impl_->cache; }
const btOverlappingPairCache* BroadphaseAdapter::getOverlappingPairCache() const { return impl_->cache; }

void BroadphaseAdapter::getBroadphaseAabb(btVector3& aabbMin, btVector3& aabbMax) const {
  bool any = false;
  for (const Proxy* p : impl_->by_slot) {
    if (!p) continue;
    if (!any) {
      aabbMin = p->m_aabbMin;
      aabbMax = p->m_aabbMax;
      any = true;
    } else {
      aabbMin.setMin(p->m_aabbMin);
      aabbMax.setMax(p->m_aabbMax);
    }
  }
  if (!any) {
    aabbMin.setValue(0, 0, 0);
    aabbMax.setValue(0, 0, 0);
  }
}

void BroadphaseAdapter::resetPool(btDispatcher* /*dispatcher*/) {
  Impl& s = *impl_;
  if (s.bp.size() != 0) return;
  // Dead proxies stay in quarantine (marked dead): still caught if used.
  s.bp = BroadPhase(s.options);
  s.by_slot.clear();
  s.by_slot.shrink_to_fit();
  s.counters = {};
}

void BroadphaseAdapter::printStats() {
  const Impl& s = *impl_;
  const BroadphaseCounters& c = s.counters;
  const BroadPhaseUpdateStats& f = s.bp.stats();
  std::printf(
      "hbp::bullet::BroadphaseAdapter: %zu proxies (%u moving, %u static), %llu frames, last frame: %llu pairs "
      "(+%llu -%llu), %u moved, %.3f ms; total %.1f ms, pairs added %llu, removed %llu\n",
      s.bp.size(), f.moving, f.statics, static_cast<unsigned long long>(c.frames),
      static_cast<unsigned long long>(c.last_pairs), static_cast<unsigned long long>(c.last_added),
      static_cast<unsigned long long>(c.last_removed), f.moved, c.last_ms, c.total_ms,
      static_cast<unsigned long long>(c.pairs_added), static_cast<unsigned long long>(c.pairs_removed));
}

std::size_t BroadphaseAdapter::proxy_count() const { return impl_->bp.size(); }
const BroadphaseCounters& BroadphaseAdapter::counters() const { return impl_->counters; }
const BroadPhaseUpdateStats& BroadphaseAdapter::frame_stats() const { return impl_->bp.stats(); }
const BroadPhase& BroadphaseAdapter::broad_phase() const { return impl_->bp; }
const BroadPhaseOptions& BroadphaseAdapter::options() const { return impl_->options; }

}  // namespace hbp::bullet
