// SPDX-License-Identifier: MIT
// hbp::bullet::BroadphaseAdapter as Bullet's btBroadphaseInterface:
// - the pair cache holds exactly the brute-force pairs the cache's filter
//   accepts, frame after frame, while proxies move, appear and disappear;
// - it is maintained incrementally: each frame adds exactly the pairs that
//   appeared and removes exactly those that separated (persisting pairs keep
//   their cache entry);
// - rayTest / aabbTest return exactly the brute-force answer, a subset of
//   btDbvtBroadphase's on the same boxes;
// - getBroadphaseAabb, resetPool, printStats, invalid boxes;
// - the example world, side by side with btDbvtBroadphase: identical exact
//   pairs handed to the narrow phase every step; bodies removed and re-added.
#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <cstdint>
#include <limits>
#include <map>
#include <random>
#include <set>
#include <string>
#include <vector>

#include "hbp/bullet/broadphase_adapter.hpp"
#include "hbp/error.hpp"
#include "hbp/pair.hpp"
#include "integrations/world/falling_shapes_world.hpp"
#include "integrations/world/side_by_side.hpp"
#include "pair_sets.hpp"

#pragma GCC diagnostic push
#pragma GCC diagnostic ignored "-Wunused-parameter"
#pragma GCC diagnostic ignored "-Wdeprecated-copy"
#pragma GCC diagnostic ignored "-Wclass-memaccess"
#include <BulletCollision/BroadphaseCollision/btDbvtBroadphase.h>
#include <LinearMath/btAabbUtil2.h>
#pragma GCC diagnostic pop

namespace {

using hbp::Aabb;
using hbp::Pair;
using hbp::test::minus;
using hbp::bullet::BroadphaseAdapter;

// Objects carry an id (stable across frames) as their user pointer.
void* user_of(std::uint32_t id) { return reinterpret_cast<void*>(static_cast<std::uintptr_t>(id) + 1); }
std::uint32_t id_of(const btBroadphaseProxy* p) {
  return static_cast<std::uint32_t>(reinterpret_cast<std::uintptr_t>(p->m_clientObject) - 1);
}

Aabb box_of(const btBroadphaseProxy* p) {
  return {{p->m_aabbMin.x(), p->m_aabbMin.y(), p->m_aabbMin.z()}, {p->m_aabbMax.x(), p->m_aabbMax.y(), p->m_aabbMax.z()}};
}

float uniform(std::mt19937& rng, float lo, float hi) {
  return lo + (hi - lo) * static_cast<float>(rng() >> 8) * (1.0f / 16777216.0f);
}

// A random box with its min corner in a cube of side `extent` (m), 0.5 .. 4 m
// a side; coordinates snapped to a 1/4 m grid now and then so that touching
// faces occur.
void random_box(std::mt19937& rng, btVector3& lo, btVector3& hi, float extent = 40) {
  const bool snap = rng() % 3 == 0;
  for (int k = 0; k < 3; ++k) {
    float a = uniform(rng, 0, extent), s = uniform(rng, 0.5f, 4);
    if (snap) {
      a = std::round(a * 4) / 4;
      s = std::round(s * 4) / 4;
    }
    lo[k] = a;
    hi[k] = a + s;
  }
}

// The pairs in a cache, as sorted canonical id pairs.
std::vector<Pair> cache_pairs(const btOverlappingPairCache& cache) {
  std::vector<Pair> out;
  const int n = cache.getNumOverlappingPairs();
  const btBroadphasePair* pairs = cache.getOverlappingPairArrayPtr();
  for (int i = 0; i < n; ++i) out.push_back(hbp::make_pair(id_of(pairs[i].m_pProxy0), id_of(pairs[i].m_pProxy1)));
  EXPECT_EQ(hbp::canonicalize(out), 0u) << "the cache holds a pair twice";
  return out;
}

// Brute force over the live proxies: overlapping exact AABBs that the cache's
// filter accepts.
std::vector<Pair> expected_pairs(const std::vector<btBroadphaseProxy*>& proxies, btOverlappingPairCache& cache) {
  std::vector<Pair> out;
  for (std::size_t i = 0; i < proxies.size(); ++i)
    for (std::size_t j = i + 1; j < proxies.size(); ++j)
      if (hbp::overlaps(box_of(proxies[i]), box_of(proxies[j])) &&
          cache.needsBroadphaseCollision(proxies[i], proxies[j]))
        out.push_back(hbp::make_pair(id_of(proxies[i]), id_of(proxies[j])));
  hbp::sort_pairs(out);
  return out;
}

// Sees every pair the cache creates or deletes.
struct PairLog : btOverlappingPairCallback {
  btBroadphasePair* addOverlappingPair(btBroadphaseProxy* a, btBroadphaseProxy* b) override {
    added.push_back(hbp::make_pair(id_of(a), id_of(b)));
    return nullptr;
  }
  void* removeOverlappingPair(btBroadphaseProxy* a, btBroadphaseProxy* b, btDispatcher*) override {
    removed.push_back(hbp::make_pair(id_of(a), id_of(b)));
    return nullptr;
  }
  void removeOverlappingPairsContainingProxy(btBroadphaseProxy*, btDispatcher*) override {}
  void clear() {
    added.clear();
    removed.clear();
  }
  std::vector<Pair> sorted_added() {
    hbp::sort_pairs(added);
    return added;
  }
  std::vector<Pair> sorted_removed() {
    hbp::sort_pairs(removed);
    return removed;
  }
  std::vector<Pair> added, removed;
};

TEST(BulletBroadphase, CacheIsExactAndIncrementalUnderChurn) {
  btHashedOverlappingPairCache cache;
  PairLog log;
  static_cast<btOverlappingPairCache&>(cache).setInternalGhostPairCallback(&log);
  BroadphaseAdapter bp(&cache, {.engine = "sw", .threads = 2});
  std::mt19937 rng(7);
  std::vector<btBroadphaseProxy*> live;
  std::uint32_t next_id = 0;
  // Groups 1, 2, 4; masks drop one group now and then.
  auto create = [&] {
    btVector3 lo, hi;
    random_box(rng, lo, hi, 25);
    const int group = 1 << (rng() % 3);
    const int mask = rng() % 4 == 0 ? (7 & ~(1 << (rng() % 3))) : 7;
    live.push_back(bp.createProxy(lo, hi, BOX_SHAPE_PROXYTYPE, user_of(next_id++), group, mask, nullptr));
  };
  for (int i = 0; i < 400; ++i) create();

  std::vector<Pair> before;  // the cache after the last frame
  std::uint64_t total_pairs = 0, total_changes = 0, filtered_out = 0;
  for (int frame = 0; frame < 40; ++frame) {
    if (frame > 0) {
      // Destroy a few (anywhere in the dense order), create a few.
      const int destroy = static_cast<int>(rng() % 12);
      for (int k = 0; k < destroy && !live.empty(); ++k) {
        const std::size_t victim = rng() % live.size();
        log.clear();
        const std::uint32_t id = id_of(live[victim]);
        bp.destroyProxy(live[victim], nullptr);
        live.erase(live.begin() + static_cast<std::ptrdiff_t>(victim));
        // Its pairs leave the cache at once.
        std::vector<Pair> gone;
        for (const Pair& p : before)
          if (p.a == id || p.b == id) gone.push_back(p);
        EXPECT_EQ(log.sorted_removed(), gone) << "frame " << frame;
        before = minus(before, gone);
      }
      const int add = static_cast<int>(rng() % 12);
      for (int k = 0; k < add; ++k) create();
      // Move most proxies a little, teleport a few.
      for (btBroadphaseProxy* p : live) {
        btVector3 lo, hi;
        bp.getAabb(p, lo, hi);
        if (rng() % 50 == 0) {
          random_box(rng, lo, hi, 25);
        } else if (rng() % 4 != 0) {
          const btVector3 d(uniform(rng, -0.4f, 0.4f), uniform(rng, -0.4f, 0.4f), uniform(rng, -0.4f, 0.4f));
          lo += d;
          hi += d;
        }
        bp.setAabb(p, lo, hi, nullptr);
      }
    }
    log.clear();
    bp.calculateOverlappingPairs(nullptr);
    const std::vector<Pair> expected = expected_pairs(live, cache);
    const std::vector<Pair> actual = cache_pairs(cache);
    ASSERT_TRUE(hbp::diff_pairs(expected, actual).empty())
        << "frame " << frame << ": " << hbp::diff_pairs(expected, actual).summary();
    // Incremental: exactly the appeared pairs were added, the separated ones removed.
    EXPECT_EQ(log.sorted_added(), minus(actual, before)) << "frame " << frame;
    EXPECT_EQ(log.sorted_removed(), minus(before, actual)) << "frame " << frame;
    filtered_out += bp.counters().last_pairs - actual.size();
    total_changes += log.added.size() + log.removed.size();
    total_pairs += actual.size();
    before = actual;
    EXPECT_EQ(bp.proxy_count(), live.size());
  }
  // The scene is not trivial: pairs, changes and filtered pairs all occur.
  EXPECT_GT(total_pairs, 40u * 250u);
  EXPECT_GT(total_changes, 40u * 50u);
  EXPECT_GT(filtered_out, 40u * 20u);
  std::printf("churn: %llu pairs, %llu cache changes, %llu pairs filtered over 40 frames\n",
              static_cast<unsigned long long>(total_pairs), static_cast<unsigned long long>(total_changes),
              static_cast<unsigned long long>(filtered_out));
  for (btBroadphaseProxy* p : live) bp.destroyProxy(p, nullptr);
  EXPECT_EQ(cache.getNumOverlappingPairs(), 0);
}

// Destroying proxy 0 moves the last proxy into its slot: the pair between
// the two survivors persists (no remove and re-add), and a proxy created in
// the same frame gets its pairs.
TEST(BulletBroadphase, DoublePrecisionIsRefusedAtConstruction) {
  EXPECT_THROW(BroadphaseAdapter(hbp::BroadPhaseOptions{.double_precision = true}), hbp::InvalidInput);
}

TEST(BulletBroadphase, SwapRemovalKeepsPersistingPairs) {
  btHashedOverlappingPairCache cache;
  PairLog log;
  static_cast<btOverlappingPairCache&>(cache).setInternalGhostPairCallback(&log);
  BroadphaseAdapter bp(&cache);
  auto make = [&](std::uint32_t id, float x) {
    return bp.createProxy(btVector3(x, 0, 0), btVector3(x + 1, 1, 1), BOX_SHAPE_PROXYTYPE, user_of(id), 1, -1,
                          nullptr);
  };
  btBroadphaseProxy* a = make(0, 0.0f);   // touches b
  btBroadphaseProxy* b = make(1, 1.0f);   // touches a and c
  btBroadphaseProxy* c = make(2, 2.0f);   // touches b
  bp.calculateOverlappingPairs(nullptr);
  EXPECT_EQ(cache_pairs(cache), (std::vector<Pair>{{0, 1}, {1, 2}}));
  EXPECT_EQ(log.added.size(), 2u);

  log.clear();
  bp.destroyProxy(a, nullptr);
  EXPECT_EQ(log.removed, (std::vector<Pair>{{0, 1}}));
  btBroadphaseProxy* d = make(3, 2.5f);  // overlaps b? no (b ends at 2); overlaps c
  log.clear();
  bp.calculateOverlappingPairs(nullptr);
  EXPECT_EQ(log.added, (std::vector<Pair>{{2, 3}}));
  EXPECT_TRUE(log.removed.empty());
  EXPECT_EQ(cache_pairs(cache), (std::vector<Pair>{{1, 2}, {2, 3}}));

  // Moving c away drops both of its pairs; nothing else changes.
  bp.setAabb(c, btVector3(10, 0, 0), btVector3(11, 1, 1), nullptr);
  log.clear();
  bp.calculateOverlappingPairs(nullptr);
  EXPECT_TRUE(log.added.empty());
  EXPECT_EQ(log.sorted_removed(), (std::vector<Pair>{{1, 2}, {2, 3}}));
  EXPECT_EQ(cache.getNumOverlappingPairs(), 0);
  EXPECT_EQ(bp.counters().pairs_added, 3u);
  EXPECT_EQ(bp.counters().pairs_removed, 2u);
  for (btBroadphaseProxy* p : {b, c, d}) bp.destroyProxy(p, nullptr);
}

// A btOverlapFilterCallback on the cache is honoured like group/mask.
struct OddEvenFilter : btOverlapFilterCallback {
  bool needBroadphaseCollision(btBroadphaseProxy* a, btBroadphaseProxy* b) const override {
    return (id_of(a) + id_of(b)) % 2 == 1;  // only odd-even pairs
  }
};

TEST(BulletBroadphase, FilterCallbackHonoured) {
  btHashedOverlappingPairCache cache;
  OddEvenFilter filter;
  cache.setOverlapFilterCallback(&filter);
  BroadphaseAdapter bp(&cache);
  std::vector<btBroadphaseProxy*> live;
  for (std::uint32_t i = 0; i < 10; ++i)  // all overlap each other
    live.push_back(bp.createProxy(btVector3(0, 0, 0) + btVector3(0.1f * i, 0, 0), btVector3(2, 2, 2),
                                  BOX_SHAPE_PROXYTYPE, user_of(i), 1, -1, nullptr));
  bp.calculateOverlappingPairs(nullptr);
  EXPECT_EQ(bp.counters().last_pairs, 45u);
  EXPECT_EQ(cache.getNumOverlappingPairs(), 25);  // 5 odd x 5 even
  EXPECT_EQ(cache_pairs(cache), expected_pairs(live, cache));
  for (btBroadphaseProxy* p : live) bp.destroyProxy(p, nullptr);
}

// Bullet's ray callback set-up (as btCollisionWorld's single-ray callback
// does): normalised direction, inverse with BT_LARGE_FLOAT for zero
// components, lambda_max the segment length. Records what it is given.
struct RayCollector : btBroadphaseRayCallback {
  RayCollector(const btVector3& from, const btVector3& to) {
    btVector3 dir = to - from;
    dir.normalize();
    for (int k = 0; k < 3; ++k) m_rayDirectionInverse[k] = dir[k] == 0 ? BT_LARGE_FLOAT : 1 / dir[k];
    for (int k = 0; k < 3; ++k) m_signs[k] = m_rayDirectionInverse[k] < 0 ? 1 : 0;
    m_lambda_max = dir.dot(to - from);
  }
  bool process(const btBroadphaseProxy* p) override {
    ids.push_back(id_of(p));
    return true;
  }
  std::vector<std::uint32_t> ids;
};

struct BoxCollector : btBroadphaseAabbCallback {
  bool process(const btBroadphaseProxy* p) override {
    ids.push_back(id_of(p));
    return true;
  }
  std::vector<std::uint32_t> ids;
};

std::vector<std::uint32_t> sorted(std::vector<std::uint32_t> v) {
  std::sort(v.begin(), v.end());
  return v;
}

bool contains(const std::vector<std::uint32_t>& big, const std::vector<std::uint32_t>& small) {
  return std::includes(big.begin(), big.end(), small.begin(), small.end());
}

TEST(BulletBroadphase, RayAndBoxQueriesAreBruteForceAndInsideDbvt) {
  BroadphaseAdapter ours;
  btDbvtBroadphase dbvt;
  std::mt19937 rng(11);
  constexpr std::uint32_t kObjects = 600;
  std::vector<btBroadphaseProxy*> mine(kObjects), theirs(kObjects);
  for (std::uint32_t i = 0; i < kObjects; ++i) {
    btVector3 lo, hi;
    random_box(rng, lo, hi);
    mine[i] = ours.createProxy(lo, hi, BOX_SHAPE_PROXYTYPE, user_of(i), 1, -1, nullptr);
    theirs[i] = dbvt.createProxy(lo, hi, BOX_SHAPE_PROXYTYPE, user_of(i), 1, -1, nullptr);
  }
  // A few frames of motion: DBVT leaves get fattened and lag behind.
  for (int frame = 0; frame < 5; ++frame) {
    for (std::uint32_t i = 0; i < kObjects; ++i) {
      btVector3 lo, hi;
      ours.getAabb(mine[i], lo, hi);
      const btVector3 d(uniform(rng, -0.5f, 0.5f), uniform(rng, -0.5f, 0.5f), uniform(rng, -0.5f, 0.5f));
      ours.setAabb(mine[i], lo + d, hi + d, nullptr);
      dbvt.setAabb(theirs[i], lo + d, hi + d, nullptr);
    }
    ours.calculateOverlappingPairs(nullptr);
    dbvt.calculateOverlappingPairs(nullptr);
  }

  std::uint64_t ray_hits = 0, dbvt_ray_hits = 0, box_hits = 0, dbvt_box_hits = 0, empty_rays = 0;
  for (int q = 0; q < 400; ++q) {
    // Rays: random segments, a quarter axis-aligned (zero direction components).
    btVector3 from(uniform(rng, -5, 45), uniform(rng, -5, 45), uniform(rng, -5, 45));
    btVector3 to(uniform(rng, -5, 45), uniform(rng, -5, 45), uniform(rng, -5, 45));
    if (q % 4 == 0) {
      to = from;
      to[q / 4 % 3] += uniform(rng, -40, 40);
    }
    // Half of them swept boxes (convex casts grow the boxes by the query box).
    btVector3 qlo(0, 0, 0), qhi(0, 0, 0);
    if (q % 2 == 1) {
      qlo = btVector3(uniform(rng, -1, 0), uniform(rng, -1, 0), uniform(rng, -1, 0));
      qhi = btVector3(uniform(rng, 0, 1), uniform(rng, 0, 1), uniform(rng, 0, 1));
    }
    RayCollector r_ours(from, to), r_dbvt(from, to);
    ours.rayTest(from, to, r_ours, qlo, qhi);
    dbvt.rayTest(from, to, r_dbvt, qlo, qhi);
    std::vector<std::uint32_t> brute;
    for (std::uint32_t i = 0; i < kObjects; ++i) {
      const btVector3 bounds[2] = {mine[i]->m_aabbMin - qhi, mine[i]->m_aabbMax - qlo};
      btScalar t;
      if (btRayAabb2(from, r_ours.m_rayDirectionInverse, r_ours.m_signs, bounds, t, 0, r_ours.m_lambda_max))
        brute.push_back(i);
    }
    const auto got = sorted(r_ours.ids);
    EXPECT_EQ(got, brute) << "ray " << q;
    EXPECT_TRUE(contains(sorted(r_dbvt.ids), got)) << "ray " << q;
    ray_hits += got.size();
    dbvt_ray_hits += r_dbvt.ids.size();
    empty_rays += got.empty() ? 1 : 0;

    // Boxes: random, some exactly touching an object's face.
    btVector3 lo, hi;
    random_box(rng, lo, hi);
    if (q % 3 == 0) {
      const btBroadphaseProxy* p = mine[rng() % kObjects];
      lo = p->m_aabbMax;
      hi = lo + btVector3(2, 2, 2);
    }
    BoxCollector b_ours, b_dbvt;
    ours.aabbTest(lo, hi, b_ours);
    dbvt.aabbTest(lo, hi, b_dbvt);
    std::vector<std::uint32_t> brute_boxes;
    const Aabb query{{lo.x(), lo.y(), lo.z()}, {hi.x(), hi.y(), hi.z()}};
    for (std::uint32_t i = 0; i < kObjects; ++i)
      if (hbp::overlaps(box_of(mine[i]), query)) brute_boxes.push_back(i);
    const auto got_boxes = sorted(b_ours.ids);
    EXPECT_EQ(got_boxes, brute_boxes) << "box " << q;
    EXPECT_TRUE(contains(sorted(b_dbvt.ids), got_boxes)) << "box " << q;
    if (q % 3 == 0) {
      EXPECT_FALSE(got_boxes.empty()) << "a box touching an object's corner finds it";
    }
    box_hits += got_boxes.size();
    dbvt_box_hits += b_dbvt.ids.size();
  }
  // Non-trivial queries, and DBVT's answers are strictly larger overall.
  EXPECT_GT(ray_hits, 400u);
  EXPECT_GT(empty_rays, 0u);
  EXPECT_GT(box_hits, 400u);
  EXPECT_GT(dbvt_ray_hits, ray_hits);
  EXPECT_GT(dbvt_box_hits, box_hits);
  for (std::uint32_t i = 0; i < kObjects; ++i) {
    ours.destroyProxy(mine[i], nullptr);
    dbvt.destroyProxy(theirs[i], nullptr);
  }
}

TEST(BulletBroadphase, BroadphaseAabbResetPoolStatsAndInvalidBoxes) {
  BroadphaseAdapter bp;
  btVector3 lo, hi;
  bp.getBroadphaseAabb(lo, hi);
  EXPECT_EQ(lo, btVector3(0, 0, 0));
  EXPECT_EQ(hi, btVector3(0, 0, 0));
  btBroadphaseProxy* a =
      bp.createProxy(btVector3(-1, 2, 3), btVector3(0, 4, 5), BOX_SHAPE_PROXYTYPE, user_of(0), 1, -1, nullptr);
  btBroadphaseProxy* b =
      bp.createProxy(btVector3(5, -7, 4), btVector3(6, 0, 9), BOX_SHAPE_PROXYTYPE, user_of(1), 1, -1, nullptr);
  EXPECT_EQ(a->m_uniqueId, 1);
  EXPECT_EQ(b->m_uniqueId, 2);
  bp.getBroadphaseAabb(lo, hi);
  EXPECT_EQ(lo, btVector3(-1, -7, 3));
  EXPECT_EQ(hi, btVector3(6, 4, 9));

  // A NaN box: setAabb throws, naming the proxy, and changes nothing; fixed,
  // the next works.
  EXPECT_THROW(bp.setAabb(b, btVector3(std::numeric_limits<float>::quiet_NaN(), 0, 0), btVector3(1, 1, 1), nullptr),
               hbp::InvalidInput);
  EXPECT_THROW(bp.createProxy(btVector3(1, 1, 1), btVector3(0, 2, 2), BOX_SHAPE_PROXYTYPE, user_of(9), 1, -1, nullptr),
               hbp::InvalidInput);
  EXPECT_EQ(bp.proxy_count(), 2u);
  bp.calculateOverlappingPairs(nullptr);
  EXPECT_EQ(bp.getOverlappingPairCache()->getNumOverlappingPairs(), 0);
  bp.setAabb(b, btVector3(-0.5f, 3, 4), btVector3(1, 6, 6), nullptr);
  bp.calculateOverlappingPairs(nullptr);
  EXPECT_EQ(bp.getOverlappingPairCache()->getNumOverlappingPairs(), 1);

  testing::internal::CaptureStdout();
  bp.printStats();
  const std::string stats = testing::internal::GetCapturedStdout();
  EXPECT_NE(stats.find("2 proxies"), std::string::npos) << stats;
  EXPECT_NE(stats.find("1 pairs"), std::string::npos) << stats;

  // resetPool with live proxies does nothing; on an empty pool it restarts ids.
  bp.resetPool(nullptr);
  btBroadphaseProxy* c =
      bp.createProxy(btVector3(0, 0, 0), btVector3(1, 1, 1), BOX_SHAPE_PROXYTYPE, user_of(2), 1, -1, nullptr);
  EXPECT_EQ(c->m_uniqueId, 3);
  for (btBroadphaseProxy* p : {a, b, c}) bp.destroyProxy(p, nullptr);
  EXPECT_EQ(bp.getOverlappingPairCache()->getNumOverlappingPairs(), 0);
  bp.resetPool(nullptr);
  btBroadphaseProxy* d =
      bp.createProxy(btVector3(0, 0, 0), btVector3(1, 1, 1), BOX_SHAPE_PROXYTYPE, user_of(3), 1, -1, nullptr);
  EXPECT_EQ(d->m_uniqueId, 1);
  EXPECT_EQ(bp.counters().frames, 0u);
  bp.destroyProxy(d, nullptr);
}

using hbp::bullet::world::FallingShapesConfig;
using hbp::bullet::world::FallingShapesWorld;

// The exact pairs a world's broad phase should hand over: brute force over
// every body's proxy, filtered by the cache.
std::vector<Pair> world_brute_force(FallingShapesWorld& world) {
  std::vector<Pair> out;
  btOverlappingPairCache& cache = *world.broadphase().getOverlappingPairCache();
  std::vector<btBroadphaseProxy*> proxies;
  for (std::size_t i = 0; i < world.body_count(); ++i)
    if (world.body(i).getBroadphaseHandle()) proxies.push_back(world.body(i).getBroadphaseHandle());
  for (std::size_t i = 0; i < proxies.size(); ++i)
    for (std::size_t j = i + 1; j < proxies.size(); ++j)
      if (hbp::overlaps(box_of(proxies[i]), box_of(proxies[j])) && cache.needsBroadphaseCollision(proxies[i], proxies[j]))
        out.push_back(hbp::make_pair(
            static_cast<std::uint32_t>(static_cast<btCollisionObject*>(proxies[i]->m_clientObject)->getUserIndex()),
            static_cast<std::uint32_t>(static_cast<btCollisionObject*>(proxies[j]->m_clientObject)->getUserIndex())));
  hbp::sort_pairs(out);
  return out;
}

// A smaller version of the documented 5,000-body, 600-step run (docs/bullet.md).
TEST(BulletWorld, SideBySideWithDbvtIdenticalPairsEveryStep) {
  FallingShapesConfig config;
  config.bodies = 800;
  config.layers_hint = 12;
  std::uint32_t dbvt_superset_steps = 0;
  const auto summary = hbp::bullet::world::run_side_by_side(
      config, 200, {.engine = "sw", .threads = 2}, [&](const hbp::bullet::world::StepComparison& c) {
        EXPECT_TRUE(c.same_aabbs) << "step " << c.step;
        EXPECT_TRUE(c.same_pairs) << "step " << c.step << ": " << c.difference;
        EXPECT_EQ(c.hybrid_raw, c.hybrid_exact) << "step " << c.step << ": our cache holds only exact pairs";
        EXPECT_GE(c.dbvt_raw, c.dbvt_exact);
        EXPECT_EQ(c.hybrid_contacts.points, c.dbvt_contacts.points) << "step " << c.step;
        dbvt_superset_steps += c.dbvt_raw > c.dbvt_exact ? 1 : 0;
      });
  EXPECT_EQ(summary.steps, 200u);
  EXPECT_EQ(summary.identical_steps, 200u);
  EXPECT_EQ(summary.first_mismatch, 0u);
  // The bodies reach the floor and pile up: thousands of pairs per step.
  EXPECT_GT(summary.max_pairs, 2000u);
  EXPECT_GT(dbvt_superset_steps, 100u) << "DBVT's cache should hold non-exact pairs (fattened leaves)";
}

TEST(BulletWorld, FilterAndBodiesRemovedAndReAdded) {
  FallingShapesConfig config;
  config.bodies = 600;
  config.layers_hint = 6;
  FallingShapesWorld world(config, std::make_unique<BroadphaseAdapter>(hbp::BroadPhaseOptions{.threads = 2}));
  world.dispatcher().set_recording(true);
  for (int s = 0; s < 120; ++s) world.step();
  EXPECT_EQ(world.dispatcher().last().exact, world_brute_force(world));
  EXPECT_EQ(world.dispatcher().last().raw, world.dispatcher().last().exact.size());

  // Filtering is visible: the static container parts overlap one another and
  // debris bodies overlap debris, yet none of those pairs is handed over.
  std::uint32_t filtered = 0;
  for (std::size_t i = 0; i < world.body_count(); ++i)
    for (std::size_t j = i + 1; j < world.body_count(); ++j) {
      btBroadphaseProxy* a = world.body(i).getBroadphaseHandle();
      btBroadphaseProxy* b = world.body(j).getBroadphaseHandle();
      if (hbp::overlaps(box_of(a), box_of(b)) && !world.broadphase().getOverlappingPairCache()->needsBroadphaseCollision(a, b))
        ++filtered;
    }
  EXPECT_GE(filtered, 4u) << "floor-wall pairs at least";

  // Remove every 7th falling body, step, re-add them, step: the handed pairs
  // stay the brute-force ones.
  std::vector<btRigidBody*> removed;
  for (std::size_t i = 5; i < world.body_count(); i += 7) {
    removed.push_back(&world.body(i));
    world.dynamics().removeRigidBody(&world.body(i));
  }
  for (int s = 0; s < 10; ++s) {
    world.step();
    EXPECT_EQ(world.dispatcher().last().exact, world_brute_force(world)) << "after removal, step " << s;
  }
  for (btRigidBody* body : removed) {
    body->activate(true);
    world.dynamics().addRigidBody(body);
  }
  for (int s = 0; s < 10; ++s) {
    world.step();
    const auto expected = world_brute_force(world);
    EXPECT_EQ(world.dispatcher().last().exact, expected) << "after re-adding, step " << s;
    EXPECT_EQ(world.dispatcher().last().raw, expected.size());
  }
  EXPECT_GT(world.dispatcher().last().exact.size(), 500u);
}

// A destroyed proxy used again is caught (it used to
// rewrite the box of whichever live proxy took its dense slot: phantom pairs).
TEST(BulletBroadphase, StaleProxyIsRejectedNotAppliedToAnother) {
  BroadphaseAdapter bp;
  btBroadphaseProxy* a =
      bp.createProxy(btVector3(0, 0, 0), btVector3(1, 1, 1), BOX_SHAPE_PROXYTYPE, user_of(0), 1, -1, nullptr);
  btBroadphaseProxy* b =
      bp.createProxy(btVector3(5, 0, 0), btVector3(6, 1, 1), BOX_SHAPE_PROXYTYPE, user_of(1), 1, -1, nullptr);
  btBroadphaseProxy* c =
      bp.createProxy(btVector3(10, 0, 0), btVector3(11, 1, 1), BOX_SHAPE_PROXYTYPE, user_of(2), 1, -1, nullptr);
  bp.calculateOverlappingPairs(nullptr);
  EXPECT_EQ(bp.getOverlappingPairCache()->getNumOverlappingPairs(), 0);
  bp.destroyProxy(a, nullptr);
  // A new proxy takes a's slot (same unique id), not its memory.
  btBroadphaseProxy* d =
      bp.createProxy(btVector3(20, 0, 0), btVector3(21, 1, 1), BOX_SHAPE_PROXYTYPE, user_of(3), 1, -1, nullptr);
  EXPECT_NE(d, a);
  EXPECT_EQ(d->m_uniqueId, 1);
  // The stale proxy moved onto b: refused, loudly, naming the call.
  try {
    bp.setAabb(a, btVector3(5, 0, 0), btVector3(6, 1, 1), nullptr);
    ADD_FAILURE() << "setAabb on a destroyed proxy did not throw";
  } catch (const hbp::InvalidInput& e) {
    EXPECT_NE(std::string(e.what()).find("setAabb"), std::string::npos) << e.what();
    EXPECT_NE(std::string(e.what()).find("destroyed"), std::string::npos) << e.what();
  }
  btVector3 lo, hi;
  EXPECT_THROW(bp.getAabb(a, lo, hi), hbp::InvalidInput);
  EXPECT_THROW(bp.destroyProxy(a, nullptr), hbp::InvalidInput);
  // Nothing else changed: no phantom pair, d kept its box.
  bp.calculateOverlappingPairs(nullptr);
  EXPECT_EQ(bp.getOverlappingPairCache()->getNumOverlappingPairs(), 0);
  bp.getAabb(d, lo, hi);
  EXPECT_EQ(lo, btVector3(20, 0, 0));
  EXPECT_EQ(bp.proxy_count(), 3u);
  // Churn: many destroyed proxies, each caught while in quarantine.
  std::vector<btBroadphaseProxy*> dead;
  for (int i = 0; i < 200; ++i) {
    btBroadphaseProxy* p = bp.createProxy(btVector3(0, 0, float(i)), btVector3(1, 1, float(i) + 1),
                                          BOX_SHAPE_PROXYTYPE, user_of(100 + i), 1, -1, nullptr);
    bp.calculateOverlappingPairs(nullptr);
    bp.destroyProxy(p, nullptr);
    dead.push_back(p);
  }
  for (btBroadphaseProxy* p : dead)
    EXPECT_THROW(bp.setAabb(p, btVector3(5, 0, 0), btVector3(6, 1, 1), nullptr), hbp::InvalidInput);
  bp.calculateOverlappingPairs(nullptr);
  EXPECT_EQ(bp.getOverlappingPairCache()->getNumOverlappingPairs(), 0);
  for (btBroadphaseProxy* p : {b, c, d}) bp.destroyProxy(p, nullptr);
}

}  // namespace

namespace {

struct CountHits : btBroadphaseAabbCallback {
  bool process(const btBroadphaseProxy*) override {
    ++hits;
    return true;
  }
  std::size_t hits = 0;
};

struct CountRayHits : btBroadphaseRayCallback {
  bool process(const btBroadphaseProxy*) override {
    ++hits;
    return true;
  }
  std::size_t hits = 0;
};

}  // namespace

// rayTest and aabbTest between setAabb / createProxy / destroyProxy and
// calculateOverlappingPairs: the cache stays exactly the brute force, with
// static proxies created, moved and destroyed among quiet dynamic ones
// (a query must never hide an edit from the next frame).
TEST(BulletBroadphase, QueriesBetweenEditsAndFrameKeepTheCacheExact) {
  btHashedOverlappingPairCache cache;
  BroadphaseAdapter bp(&cache, {.engine = "sw", .threads = 2});
  std::mt19937 rng(23);
  std::vector<btBroadphaseProxy*> live, statics, dynamics;
  std::uint32_t next_id = 0;
  const int kStaticMask = btBroadphaseProxy::AllFilter ^ btBroadphaseProxy::StaticFilter;
  auto create = [&](bool is_static) {
    btVector3 lo, hi;
    random_box(rng, lo, hi, 20);
    btBroadphaseProxy* p =
        is_static ? bp.createProxy(lo, hi, BOX_SHAPE_PROXYTYPE, user_of(next_id++), btBroadphaseProxy::StaticFilter,
                                   kStaticMask, nullptr)
                  : bp.createProxy(lo, hi, BOX_SHAPE_PROXYTYPE, user_of(next_id++),
                                   btBroadphaseProxy::DefaultFilter, btBroadphaseProxy::AllFilter, nullptr);
    live.push_back(p);
    (is_static ? statics : dynamics).push_back(p);
  };
  auto query = [&] {
    CountHits boxes;
    btVector3 lo, hi;
    random_box(rng, lo, hi, 20);
    bp.aabbTest(lo, hi, boxes);
    CountRayHits rays;
    const btVector3 from(-5, 10, 10), to(30, 10, 10);
    const btVector3 dir = (to - from).normalized();
    rays.m_rayDirectionInverse = btVector3(1 / dir.x(), dir.y() == 0 ? BT_LARGE_FLOAT : 1 / dir.y(),
                                           dir.z() == 0 ? BT_LARGE_FLOAT : 1 / dir.z());
    for (int k = 0; k < 3; ++k) rays.m_signs[k] = rays.m_rayDirectionInverse[k] < 0.0;
    rays.m_lambda_max = dir.dot(to - from);
    bp.rayTest(from, to, rays);
  };
  for (int i = 0; i < 150; ++i) create(false);
  for (int i = 0; i < 150; ++i) create(true);
  bp.calculateOverlappingPairs(nullptr);
  std::uint64_t static_pairs = 0;
  for (int frame = 0; frame < 30; ++frame) {
    switch (frame % 3) {
      case 0: {  // a static moves
        btBroadphaseProxy* p = statics[rng() % statics.size()];
        btVector3 lo, hi;
        random_box(rng, lo, hi, 20);
        bp.setAabb(p, lo, hi, nullptr);
        break;
      }
      case 1:  // a static appears
        create(true);
        break;
      default: {  // a dynamic one goes
        const std::size_t v = rng() % dynamics.size();
        btBroadphaseProxy* p = dynamics[v];
        dynamics.erase(dynamics.begin() + static_cast<std::ptrdiff_t>(v));
        live.erase(std::find(live.begin(), live.end(), p));
        bp.destroyProxy(p, nullptr);
        break;
      }
    }
    query();
    bp.calculateOverlappingPairs(nullptr);
    const std::vector<Pair> expected = expected_pairs(live, cache);
    const std::vector<Pair> actual = cache_pairs(cache);
    ASSERT_TRUE(hbp::diff_pairs(expected, actual).empty())
        << "frame " << frame << ": " << hbp::diff_pairs(expected, actual).summary();
    for (const Pair& p : actual) static_pairs += p.a >= 150 || p.b >= 150;
  }
  EXPECT_GT(static_pairs, 30u * 20u);  // the statics take part
}
