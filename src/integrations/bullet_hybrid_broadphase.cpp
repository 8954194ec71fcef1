// hbp::bullet::HybridBroadphase: Bullet's btBroadphaseInterface over the
// hybrid system.
//
// Live proxies are kept dense: proxy k of the BoxArray is live_[k], and
// destroying a proxy moves the last one into its slot. The hybrid system
// assumes object i of one frame is object i of the next (its routing starts
// from where the object was last frame, checked against the cell region, so a
// wrong guess costs time, never pairs). Pairs are diffed in dense-index space:
// when proxies were created or destroyed since the last frame, the previous
// frame's pairs are first re-mapped through prev_to_cur_ (kept up to date by
// each create and destroy in O(1)), dropping pairs of destroyed proxies (their
// cache entries went at destroy time).
#include "hbp/bullet/hybrid_broadphase.hpp"

#include <algorithm>
#include <chrono>
#include <cstdio>
#include <limits>
#include <vector>

#pragma GCC diagnostic push
#pragma GCC diagnostic ignored "-Wunused-parameter"
#pragma GCC diagnostic ignored "-Wdeprecated-copy"
#pragma GCC diagnostic ignored "-Wunused-variable"
#pragma GCC diagnostic ignored "-Wunused-but-set-variable"
#pragma GCC diagnostic ignored "-Wclass-memaccess"
#pragma GCC diagnostic ignored "-Wmaybe-uninitialized"
#include <LinearMath/btAabbUtil2.h>
#pragma GCC diagnostic pop

#include "hbp/box_array.hpp"
#include "hbp/pair.hpp"

namespace hbp::bullet {

static_assert(sizeof(btScalar) == sizeof(float),
              "hbp::bullet::HybridBroadphase needs single-precision Bullet (the boxes are float32)");

namespace {

constexpr std::uint32_t kNone = std::numeric_limits<std::uint32_t>::max();

// A Bullet proxy that knows its slot in the dense arrays.
struct Proxy : btBroadphaseProxy {
  Proxy(const btVector3& lo, const btVector3& hi, void* user, int group, int mask)
      : btBroadphaseProxy(lo, hi, user, group, mask) {}
  std::uint32_t dense = kNone;
};

Proxy* as_proxy(btBroadphaseProxy* p) { return static_cast<Proxy*>(p); }

Aabb to_box(const btVector3& lo, const btVector3& hi) {
  return {{lo.getX(), lo.getY(), lo.getZ()}, {hi.getX(), hi.getY(), hi.getZ()}};
}

}  // namespace

struct HybridBroadphase::Impl {
  explicit Impl(btOverlappingPairCache* external, const BroadPhaseOptions& opts)
      : options(with_sorted(opts)), system(options) {
    if (external) {
      cache = external;
    } else {
      owned_cache = std::make_unique<btHashedOverlappingPairCache>();
      cache = owned_cache.get();
    }
  }

  static BroadPhaseOptions with_sorted(BroadPhaseOptions o) {
    o.sorted = true;
    return o;
  }

  int next_uid() {
    if (!free_uids.empty()) {
      const int uid = free_uids.back();
      free_uids.pop_back();
      return uid;
    }
    return ++uid_counter;
  }

  // Brings previous_ into the current dense numbering.
  void remap_previous() {
    std::size_t kept = 0;
    for (const Pair& p : previous) {
      const std::uint32_t a = prev_to_cur[p.a];
      const std::uint32_t b = prev_to_cur[p.b];
      if (a == kNone || b == kNone) continue;
      previous[kept++] = make_pair(a, b);
    }
    previous.resize(kept);
    sort_pairs(previous);
  }

  void reset_mapping() {
    const auto n = static_cast<std::uint32_t>(live.size());
    prev_to_cur.resize(n);
    cur_to_prev.resize(n);
    for (std::uint32_t i = 0; i < n; ++i) prev_to_cur[i] = cur_to_prev[i] = i;
    structure_changed = false;
  }

  BroadPhaseOptions options;
  HybridBroadPhase system;
  std::unique_ptr<btHashedOverlappingPairCache> owned_cache;
  btOverlappingPairCache* cache = nullptr;

  std::vector<Proxy*> live;  // dense index -> proxy
  BoxArray boxes;            // dense index -> exact AABB
  std::vector<Pair> previous;  // pairs of the last frame (dense indices then)
  // Dense index of the last frame -> now (kNone: destroyed), and back
  // (kNone: created since). Identity after each frame.
  std::vector<std::uint32_t> prev_to_cur, cur_to_prev;
  bool structure_changed = false;

  int uid_counter = 0;
  std::vector<int> free_uids;
  BroadphaseCounters counters;
};

HybridBroadphase::HybridBroadphase(btOverlappingPairCache* cache, const BroadPhaseOptions& options)
    : impl_(std::make_unique<Impl>(cache, options)) {}

HybridBroadphase::~HybridBroadphase() {
  for (Proxy* p : impl_->live) delete p;
}

btBroadphaseProxy* HybridBroadphase::createProxy(const btVector3& aabbMin, const btVector3& aabbMax, int /*shapeType*/,
                                                 void* userPtr, int collisionFilterGroup, int collisionFilterMask,
                                                 btDispatcher* /*dispatcher*/) {
  Impl& s = *impl_;
  auto* proxy = new Proxy(aabbMin, aabbMax, userPtr, collisionFilterGroup, collisionFilterMask);
  proxy->m_uniqueId = s.next_uid();
  proxy->dense = static_cast<std::uint32_t>(s.live.size());
  s.live.push_back(proxy);
  s.boxes.push_back(to_box(aabbMin, aabbMax));
  s.cur_to_prev.push_back(kNone);
  s.structure_changed = true;
  ++s.counters.proxies_created;
  return proxy;
}

void HybridBroadphase::destroyProxy(btBroadphaseProxy* proxy, btDispatcher* dispatcher) {
  Impl& s = *impl_;
  Proxy* p = as_proxy(proxy);
  s.cache->removeOverlappingPairsContainingProxy(p, dispatcher);
  const std::uint32_t d = p->dense;
  const auto last = static_cast<std::uint32_t>(s.live.size() - 1);
  if (s.cur_to_prev[d] != kNone) s.prev_to_cur[s.cur_to_prev[d]] = kNone;
  if (d != last) {
    Proxy* moved = s.live[last];
    moved->dense = d;
    s.live[d] = moved;
    s.boxes.set(d, s.boxes.get(last));
    s.cur_to_prev[d] = s.cur_to_prev[last];
    if (s.cur_to_prev[d] != kNone) s.prev_to_cur[s.cur_to_prev[d]] = d;
  }
  s.live.pop_back();
  s.boxes.resize(last);
  s.cur_to_prev.pop_back();
  s.structure_changed = true;
  s.free_uids.push_back(p->m_uniqueId);
  ++s.counters.proxies_destroyed;
  delete p;
}

void HybridBroadphase::setAabb(btBroadphaseProxy* proxy, const btVector3& aabbMin, const btVector3& aabbMax,
                               btDispatcher* /*dispatcher*/) {
  Proxy* p = as_proxy(proxy);
  p->m_aabbMin = aabbMin;
  p->m_aabbMax = aabbMax;
  impl_->boxes.set(p->dense, to_box(aabbMin, aabbMax));
}

void HybridBroadphase::getAabb(btBroadphaseProxy* proxy, btVector3& aabbMin, btVector3& aabbMax) const {
  aabbMin = proxy->m_aabbMin;
  aabbMax = proxy->m_aabbMax;
}

void HybridBroadphase::rayTest(const btVector3& rayFrom, const btVector3& /*rayTo*/,
                               btBroadphaseRayCallback& rayCallback, const btVector3& aabbMin,
                               const btVector3& aabbMax) {
  Impl& s = *impl_;
  const btScalar lambda_max = rayCallback.m_lambda_max;
  const btVector3 inverse = rayCallback.m_rayDirectionInverse;
  const unsigned int signs[3] = {rayCallback.m_signs[0], rayCallback.m_signs[1], rayCallback.m_signs[2]};
  // Hits first, callbacks after: process() may query this broad phase again.
  std::vector<Proxy*> proxies;
  const auto n = static_cast<std::uint32_t>(s.live.size());
  for (std::uint32_t i = 0; i < n; ++i) {
    const btVector3 bounds[2] = {
        btVector3(s.boxes.min(0)[i], s.boxes.min(1)[i], s.boxes.min(2)[i]) - aabbMax,
        btVector3(s.boxes.max(0)[i], s.boxes.max(1)[i], s.boxes.max(2)[i]) - aabbMin};
    btScalar tmin;
    if (btRayAabb2(rayFrom, inverse, signs, bounds, tmin, 0, lambda_max)) proxies.push_back(s.live[i]);
  }
  for (Proxy* p : proxies) rayCallback.process(p);
}

void HybridBroadphase::aabbTest(const btVector3& aabbMin, const btVector3& aabbMax,
                                btBroadphaseAabbCallback& callback) {
  Impl& s = *impl_;
  const float lo[3] = {aabbMin.getX(), aabbMin.getY(), aabbMin.getZ()};
  const float hi[3] = {aabbMax.getX(), aabbMax.getY(), aabbMax.getZ()};
  std::vector<Proxy*> proxies;
  const auto n = static_cast<std::uint32_t>(s.live.size());
  const float* mnx = s.boxes.min(0);
  const float* mny = s.boxes.min(1);
  const float* mnz = s.boxes.min(2);
  const float* mxx = s.boxes.max(0);
  const float* mxy = s.boxes.max(1);
  const float* mxz = s.boxes.max(2);
  for (std::uint32_t i = 0; i < n; ++i) {
    const bool hit = (mxx[i] >= lo[0]) & (mnx[i] <= hi[0]) & (mxy[i] >= lo[1]) & (mny[i] <= hi[1]) &
                     (mxz[i] >= lo[2]) & (mnz[i] <= hi[2]);
    if (hit) proxies.push_back(s.live[i]);
  }
  for (Proxy* p : proxies) callback.process(p);
}

void HybridBroadphase::calculateOverlappingPairs(btDispatcher* dispatcher) {
  Impl& s = *impl_;
  const auto start = std::chrono::steady_clock::now();
  if (s.structure_changed) {
    // Before the frame, so a frame that throws (invalid box) leaves a
    // consistent state behind.
    s.remap_previous();
    s.reset_mapping();
  }

  static const std::vector<Pair> kNoPairs;
  const std::vector<Pair>& current = s.live.size() >= 2 ? s.system.update(s.boxes) : kNoPairs;

  // Merge the two sorted sets: pairs only in `current` appeared, pairs only
  // in `previous` separated.
  std::uint64_t added = 0, removed = 0;
  auto prev = s.previous.begin();
  const auto prev_end = s.previous.end();
  for (const Pair& p : current) {
    while (prev != prev_end && *prev < p) {
      s.cache->removeOverlappingPair(s.live[prev->a], s.live[prev->b], dispatcher);
      ++removed;
      ++prev;
    }
    if (prev != prev_end && *prev == p) {
      ++prev;
      continue;
    }
    s.cache->addOverlappingPair(s.live[p.a], s.live[p.b]);
    ++added;
  }
  for (; prev != prev_end; ++prev) {
    s.cache->removeOverlappingPair(s.live[prev->a], s.live[prev->b], dispatcher);
    ++removed;
  }
  s.previous.assign(current.begin(), current.end());

  BroadphaseCounters& c = s.counters;
  ++c.frames;
  c.pairs_added += added;
  c.pairs_removed += removed;
  c.last_added = added;
  c.last_removed = removed;
  c.last_pairs = current.size();
  c.last_ms = std::chrono::duration<double, std::milli>(std::chrono::steady_clock::now() - start).count();
  c.total_ms += c.last_ms;
}

btOverlappingPairCache* HybridBroadphase::getOverlappingPairCache() { return impl_->cache; }
const btOverlappingPairCache* HybridBroadphase::getOverlappingPairCache() const { return impl_->cache; }

void HybridBroadphase::getBroadphaseAabb(btVector3& aabbMin, btVector3& aabbMax) const {
  const Impl& s = *impl_;
  const std::size_t n = s.live.size();
  if (n == 0) {
    aabbMin.setValue(0, 0, 0);
    aabbMax.setValue(0, 0, 0);
    return;
  }
  float lo[3], hi[3];
  for (int k = 0; k < 3; ++k) {
    lo[k] = *std::min_element(s.boxes.min(k), s.boxes.min(k) + n);
    hi[k] = *std::max_element(s.boxes.max(k), s.boxes.max(k) + n);
  }
  aabbMin.setValue(lo[0], lo[1], lo[2]);
  aabbMax.setValue(hi[0], hi[1], hi[2]);
}

void HybridBroadphase::resetPool(btDispatcher* /*dispatcher*/) {
  Impl& s = *impl_;
  if (!s.live.empty()) return;
  s.system = HybridBroadPhase(s.options);
  s.previous.clear();
  s.prev_to_cur.clear();
  s.cur_to_prev.clear();
  s.structure_changed = false;
  s.uid_counter = 0;
  s.free_uids.clear();
  s.counters = {};
}

void HybridBroadphase::printStats() {
  const Impl& s = *impl_;
  const BroadphaseCounters& c = s.counters;
  const FrameStats& f = s.system.stats();
  std::printf(
      "hbp::bullet::HybridBroadphase: %zu proxies, %llu frames, last frame: %llu pairs (+%llu -%llu), "
      "%u cells (min/median/max %u/%u/%u), duplication %.3f, %.3f ms (partition %.3f, engine %.3f); "
      "total %.1f ms, pairs added %llu, removed %llu\n",
      s.live.size(), static_cast<unsigned long long>(c.frames), static_cast<unsigned long long>(c.last_pairs),
      static_cast<unsigned long long>(c.last_added), static_cast<unsigned long long>(c.last_removed), f.cells,
      f.min_cell, f.median_cell, f.max_cell, f.duplication, c.last_ms, f.partition_ms, f.engine_ms, c.total_ms,
      static_cast<unsigned long long>(c.pairs_added), static_cast<unsigned long long>(c.pairs_removed));
}

std::size_t HybridBroadphase::proxy_count() const { return impl_->live.size(); }
const BroadphaseCounters& HybridBroadphase::counters() const { return impl_->counters; }
const FrameStats& HybridBroadphase::frame_stats() const { return impl_->system.stats(); }
const BroadPhaseOptions& HybridBroadphase::options() const { return impl_->options; }

}  // namespace hbp::bullet
