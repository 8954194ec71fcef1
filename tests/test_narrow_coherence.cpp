// SPDX-License-Identifier: MIT
// The narrow phase's verdicts: no contact on a pair that is apart (the
// false-contact defect on such a pair, reproduced), and the per-pair cache
// changes no verdict.
#include <gtest/gtest.h>

#include <cmath>
#include <random>
#include <string>
#include <vector>

#include "hbp/collision_pipeline.hpp"
#include "hbp/error.hpp"
#include "hbp/hybrid_broadphase.hpp"
#include "hbp/narrow/gjk.hpp"
#include "hbp/narrow/narrow_cache.hpp"
#include "hbp/narrow/narrow_phase.hpp"
#include "hbp/benchdata/random_pairs.hpp"
#include "hbp/scenario.hpp"

namespace hbp {
namespace {

Shape shape(ShapeKind kind, Vec3 pos, Vec3 size, Quat q) {
  Shape s;
  s.kind = kind;
  s.position = pos;
  s.size = size;
  s.orientation = q;
  return s;
}

// Paper scene, n = 100,000, seed 0, objects 487 (sphere) and 59408 (cuboid)
// after 3 steps: 11.5 m apart. GJK's last tetrahedron there is a sliver
// (three support points within 2e-4 m of each other and one 60 m away,
// volume / edge product 1.5e-17) whose inside test is rounding noise; it was
// accepted, EPA failed and a depth-0 contact came out.
TEST(NarrowFalseContacts, SphereCuboidPaperScenePair) {
  const Shape a = shape(ShapeKind::Sphere, {970.99952859616189, 2404.4629037890036, 2539.1265035188303},
                        {30.78478854661385, 35.783190847968001, 51.20609012667677},
                        {0.096035340470011277, 0.94555243759528296, 0.1383416641023037, 0.27851280960098207});
  const Shape b = shape(ShapeKind::Cuboid, {952.39429051111574, 2355.5708837797115, 2510.7380271366924},
                        {49.239096236395817, 71.700513675262101, 30.298789810288955},
                        {0.62263321218365497, -0.30501887372107206, 0.69924204311523397, -0.17421806708784754});
  Contact c;
  EXPECT_FALSE(intersect(a, b, &c)) << "depth " << c.depth;
  EXPECT_FALSE(intersect(a, b, nullptr));
  EXPECT_NEAR(signed_distance(a, b), 11.5036, 1e-3);
  // The full GJK (distance mode) must not accept the sliver either.
  const narrow::GjkResult g = narrow::gjk(narrow::make_convex(a), narrow::make_convex(b));
  EXPECT_FALSE(g.intersecting);
}

// The same pair in the scene itself: no frame reports it.
TEST(NarrowFalseContacts, PaperSceneFramesOfThatPair) {
  ScenarioParams p;
  p.n = 100000;
  p.seed = 0;
  p.frames = 5;
  Scenario s(p);
  for (int f = 0; f < 5; ++f) {
    if (f) s.step();
    EXPECT_FALSE(intersect(s.shapes()[487], s.shapes()[59408], nullptr)) << "frame " << f;
    Contact c;
    EXPECT_FALSE(intersect(s.shapes()[487], s.shapes()[59408], &c)) << "frame " << f << " depth " << c.depth;
  }
}

// Randomized (CI-fast): every contact is certified by the intersection-only
// test, on near-touching and overlapping pairs of every kind.
TEST(NarrowFalseContacts, ContactsImplyIntersectionOnRandomPairs) {
  ShapePairGenerator gen(16);
  int hits = 0;
  for (int i = 0; i < 5000; ++i) {
    const ShapePair p = gen.next();
    Contact c;
    const bool hit = intersect(p.a, p.b, &c);
    const bool boolean_only = intersect(p.a, p.b, nullptr);
    ASSERT_EQ(hit, boolean_only) << "pair " << i;
    hits += hit;
    if (hit) {
      EXPECT_GE(c.depth, 0);
    }
  }
  EXPECT_GT(hits, 2000);
}

TEST(NarrowCacheTest, CommitAndFind) {
  NarrowCache cache;
  std::vector<NarrowCacheEntry> l1 = {{{3, 7}, {1, 0, 0}, 0}, {{0, 2}, {0, 1, 0}, 1}};
  std::vector<NarrowCacheEntry> l2 = {{{3, 4}, {0, 0, 1}, 0}};
  const std::vector<NarrowCacheEntry> lists[] = {l1, l2};
  cache.commit(lists, 2, 8);
  EXPECT_EQ(cache.size(), 3u);
  ASSERT_NE(cache.find({3, 7}), nullptr);
  EXPECT_EQ(cache.find({3, 7})[0], 1.0f);
  ASSERT_NE(cache.find({3, 4}), nullptr);
  EXPECT_EQ(cache.find({3, 4})[2], 1.0f);
  ASSERT_NE(cache.find({0, 2}), nullptr);
  EXPECT_EQ(cache.find({0, 2})[1], 1.0f);
  ASSERT_NE(cache.entry({0, 2}), nullptr);
  EXPECT_EQ(cache.entry({0, 2})->contact, 1u);
  EXPECT_EQ(cache.entry({3, 7})->contact, 0u);
  EXPECT_EQ(cache.find({0, 3}), nullptr);
  EXPECT_EQ(cache.find({7, 9}), nullptr);
  EXPECT_EQ(cache.find({100, 101}), nullptr);
  // An id beyond the objects: refused, naming the pair, the cache unchanged.
  const std::vector<NarrowCacheEntry> bad = {{{1, 2}, {1, 0, 0}, 0}, {{3, 9}, {1, 0, 0}, 0}};
  try {
    cache.commit(&bad, 1, 8);
    ADD_FAILURE() << "no exception";
  } catch (const InvalidInput& e) {
    EXPECT_NE(std::string(e.what()).find("3-9"), std::string::npos) << e.what();
  }
  EXPECT_EQ(cache.size(), 3u);
  ASSERT_NE(cache.find({3, 7}), nullptr);
  EXPECT_EQ(cache.find({3, 7})[0], 1.0f);
  EXPECT_EQ(cache.find({1, 2}), nullptr);
  cache.commit(&l2, 1, 8);  // the next frame forgets pairs it did not see
  EXPECT_EQ(cache.find({3, 7}), nullptr);
  EXPECT_NE(cache.find({3, 4}), nullptr);
}

// Frames whose pair counts grow and shrink: the cache's storage is
// reallocated (fresh, huge-page advised, with slack) or reused, and every
// entry is found with its own direction after each commit.
TEST(NarrowCacheTest, StorageGrowsAndShrinksWithTheFrame) {
  constexpr std::uint32_t kObjects = 200'000;
  NarrowCache cache;
  for (const std::uint32_t count : {10u, 200'000u, 210'000u, 300'000u, 5u, 120'000u}) {
    std::vector<NarrowCacheEntry> list(count);
    for (std::uint32_t k = 0; k < count; ++k) {
      // Unique pairs, several per first object, in no sorted order.
      const std::uint32_t j = (k * 7919u) % count;
      list[k] = NarrowCacheEntry{{j % 100'000u, 100'000u + j / 100'000u}, {static_cast<float>(j), 0, 0}, 0};
    }
    cache.commit(&list, 1, kObjects);
    ASSERT_EQ(cache.size(), count);
    std::uint32_t wrong = 0;
    for (std::uint32_t j = 0; j < count; ++j) {
      const float* d = cache.find({j % 100'000u, 100'000u + j / 100'000u});
      if (!d || d[0] != static_cast<float>(j)) ++wrong;
    }
    EXPECT_EQ(wrong, 0u) << count << " entries";
    EXPECT_EQ(cache.find({count % 100'000u, 100'000u + count / 100'000u}), nullptr) << count << " entries";
  }
}

// Frames of a moving paper scene: with the cache warm, the contacts are the
// same pairs as without it, and the depths agree within the tolerance.
TEST(NarrowCacheTest, SameVerdictsWithAndWithoutCache) {
  ScenarioParams p;
  p.n = 3000;
  p.seed = 3;
  p.frames = 6;
  Scenario s(p);
  HybridBroadPhase bp(BroadPhaseOptions{.engine = "sw", .threads = 1});
  const NarrowPhase narrow;
  NarrowCache cache;
  std::vector<NarrowCacheEntry> learned;
  BoxArray boxes;
  std::size_t total = 0;
  for (int f = 0; f < 6; ++f) {
    if (f) s.step();
    s.compute_boxes(boxes);
    const auto& pairs = bp.update(boxes);
    std::vector<Contact> cold, warm;
    narrow.process(s.shapes(), pairs.data(), pairs.size(), cold);
    learned.clear();
    narrow.process(s.shapes(), pairs.data(), pairs.size(), warm, &cache, &learned);
    cache.commit(&learned, 1, s.size());
    ASSERT_EQ(cold.size(), warm.size()) << "frame " << f;
    for (std::size_t k = 0; k < cold.size(); ++k) {
      EXPECT_EQ(cold[k].a, warm[k].a);
      EXPECT_EQ(cold[k].b, warm[k].b);
      EXPECT_NEAR(cold[k].depth, warm[k].depth, 2 * narrow::kContactDepthTolerance * cold[k].depth + 1e-6);
    }
    // Contacts from GJK + EPA are remembered as contacts (next frame they
    // skip the quick rejects; closed forms learn nothing); pairs found apart
    // are remembered as separating axes.
    std::size_t apart = 0, remembered = 0;
    for (std::size_t k = 0, j = 0; k < pairs.size(); ++k) {
      const NarrowCacheEntry* e = cache.entry(pairs[k]);
      const bool hit = j < warm.size() && warm[j].a == pairs[k].a && warm[j].b == pairs[k].b;
      if (hit) {
        ++j;
        if (!e) continue;
        EXPECT_EQ(e->contact, 1u) << "frame " << f << " pair " << k;
        ++remembered;
      } else if (e) {
        EXPECT_EQ(e->contact, 0u) << "frame " << f << " pair " << k;
        ++apart;
      }
    }
    EXPECT_GT(apart, 0u);
    EXPECT_GT(remembered, warm.size() / 2);
    total += cold.size();
    if (f > 0) {
      EXPECT_GT(cache.size(), pairs.size() / 2) << "the cache learns most pairs";
    }
  }
  EXPECT_GT(total, 500u);
}


// GJK's enclosing test on hand-made tetrahedra: inside, outside, a face
// through the origin, a sliver.
TEST(NarrowWarmTetrahedron, EnclosingTest) {
  using narrow::V3;
  auto tet = [](V3 p0, V3 p1, V3 p2, V3 p3) {
    narrow::Simplex s;
    s.n = 4;
    const V3 p[4] = {p0, p1, p2, p3};
    for (int i = 0; i < 4; ++i) s.v[i].w = p[i];
    return s;
  };
  EXPECT_TRUE(narrow::tetrahedron_encloses_origin(tet({1, 1, 1}, {1, -1, -1}, {-1, 1, -1}, {-1, -1, 1})));
  EXPECT_TRUE(narrow::tetrahedron_encloses_origin(tet({-1, -1, 1}, {1, -1, -1}, {-1, 1, -1}, {1, 1, 1})));
  EXPECT_FALSE(narrow::tetrahedron_encloses_origin(tet({3, 1, 1}, {3, -1, -1}, {1, 1, -1}, {1, -1, 1})));
  // Origin on a face: touching counts as contact, as in GJK.
  EXPECT_TRUE(narrow::tetrahedron_encloses_origin(tet({1, 0, 0}, {-1, 1, 0}, {-1, -1, 0}, {0, 0, 1})));
  // Sliver: the origin is strictly inside, but the tetrahedron is 2e-14
  // thick against edges of 2: its face-side tests are rounding noise.
  EXPECT_FALSE(narrow::tetrahedron_encloses_origin(
      tet({1, 0, -1e-14}, {-1, 1, -1e-14}, {-1, -1, -1e-14}, {0, 0, 1e-14})));
  EXPECT_TRUE(narrow::tetrahedron_encloses_origin(tet({1, 0, -1e-3}, {-1, 1, -1e-3}, {-1, -1, -1e-3}, {0, 0, 1e-3})));
  narrow::Simplex three = tet({1, 1, 1}, {1, -1, -1}, {-1, 1, -1}, {-1, -1, 1});
  three.n = 3;
  EXPECT_FALSE(narrow::tetrahedron_encloses_origin(three));
}

// Random pairs moved over frames: the warm start of a colliding pair (the
// cone tetrahedron around last frame's normal, GJK from it where it does
// not enclose) never changes a verdict, and the depth stays within the
// tolerance of the cold path's; the cone encloses on most colliding pairs,
// and not on all.
TEST(NarrowWarmTetrahedron, SameVerdictsAndDepthsAsColdOverFrames) {
  ShapePairGenerator gen(21);
  std::mt19937_64 rng(7);
  std::uniform_real_distribution<double> u(-1, 1);
  constexpr int kPairs = 1500, kFrames = 6;
  int used = 0, warm_tries = 0, contacts = 0;
  for (int i = 0; i < kPairs; ++i) {
    ShapePair p = gen.next();
    // Curved pairs only: the closed forms learn nothing.
    if (p.a.kind == ShapeKind::Cuboid && p.b.kind == ShapeKind::Cuboid) continue;
    // Overlap most of them a little more so that contacts persist.
    p.b.position = {p.a.position.x + 0.9 * (p.b.position.x - p.a.position.x),
                    p.a.position.y + 0.9 * (p.b.position.y - p.a.position.y),
                    p.a.position.z + 0.9 * (p.b.position.z - p.a.position.z)};
    const Vec3 velocity{u(rng) * 0.5, u(rng) * 0.5, u(rng) * 0.5};
    const Vec3 spin{u(rng) * 0.02, u(rng) * 0.02, u(rng) * 0.02};
    narrow::Coherence warm, now;
    bool have_warm = false;
    for (int f = 0; f < kFrames; ++f) {
      if (f) {
        p.b.position = {p.b.position.x + velocity.x, p.b.position.y + velocity.y, p.b.position.z + velocity.z};
        p.b.orientation = integrate_rotation(p.b.orientation, spin, 1.0);
      }
      const narrow::Convex a = narrow::make_convex(p.a), b = narrow::make_convex(p.b);
      narrow::Hit cold_hit, warm_hit;
      const bool cold = narrow::intersect(a, b, &cold_hit, NarrowMethod::Auto);
      // What the cache would hold: the direction as floats.
      const narrow::V3 cached{static_cast<float>(warm.dir.x), static_cast<float>(warm.dir.y),
                              static_cast<float>(warm.dir.z)};
      warm.dir = cached;
      // (A normal is learned only where EPA ran, never by a closed form.)
      const bool tried = have_warm && warm.contact;
      const bool hot = narrow::intersect(a, b, &warm_hit, NarrowMethod::Auto, have_warm ? &warm : nullptr, &now);
      ASSERT_EQ(cold, hot) << "pair " << i << " frame " << f;
      if (hot) {
        ++contacts;
        EXPECT_NEAR(cold_hit.depth, warm_hit.depth, 2 * narrow::kContactDepthTolerance * cold_hit.depth + 1e-7)
            << "pair " << i << " frame " << f;
        // The warm depth is certified too: moving b by it separates.
        Shape moved = p.b;
        const narrow::V3 shift = warm_hit.normal * (warm_hit.depth * (1 + 1e-6) + 1e-9);
        moved.position = {moved.position.x + shift.x, moved.position.y + shift.y, moved.position.z + shift.z};
        EXPECT_FALSE(intersect(p.a, moved, nullptr)) << "pair " << i << " frame " << f;
      }
      if (tried) {
        ++warm_tries;
        used += narrow::tetrahedron_encloses_origin(narrow::cone_tetrahedron(a, b, warm.dir));
      }
      warm = now;
      have_warm = narrow::norm2(now.dir) > 0;
    }
  }
  EXPECT_GT(contacts, 2000);
  EXPECT_GT(warm_tries, 1500);
  EXPECT_GT(used, warm_tries / 2) << "the cone tetrahedron serves most colliding pairs";
  EXPECT_LT(used, warm_tries) << "and some go on with GJK";
}

// A cone tetrahedron that does not enclose the origin (here: around a
// normal pointing elsewhere) hands over to GJK, which goes on from its
// closest feature: same verdict and depth as cold, and a pair now apart is
// reported apart. A zero normal (none learned) skips the cone: GJK as on a
// cold pair. Near-touching pairs (half of these, placed 1e-7 .. 1e-2
// relative from touching) may come out differently only within the
// touching band: GJK started elsewhere may find an enclosing tetrahedron of
// real support points (a certified contact) where the cold GJK stalled at a
// distance of 1e-6 m.
TEST(NarrowWarmTetrahedron, FallsBackWhenItDoesNotEnclose) {
  ShapePairGenerator gen(4);
  std::mt19937_64 rng(9);
  std::normal_distribution<double> g;
  int hits = 0, misses = 0, band = 0, fallbacks = 0;
  for (int i = 0; i < 400; ++i) {
    const ShapePair p = gen.next(ShapeKind::Sphere, ShapeKind::Cone);
    const narrow::Convex a = narrow::make_convex(p.a), b = narrow::make_convex(p.b);
    narrow::Coherence warm;
    // Every fifth pair: no usable normal. Else a random one.
    warm.dir = {0, 0, 0};
    if (i % 5) {
      warm.dir = {g(rng), g(rng), g(rng)};
      warm.dir = warm.dir * (1 / narrow::norm(warm.dir));
      fallbacks += !narrow::tetrahedron_encloses_origin(narrow::cone_tetrahedron(a, b, warm.dir));
    }
    warm.contact = true;
    narrow::Hit cold_hit, warm_hit;
    narrow::Coherence now;
    const bool cold = narrow::intersect(a, b, &cold_hit, NarrowMethod::Auto);
    const bool hot = narrow::intersect(a, b, &warm_hit, NarrowMethod::Auto, &warm, &now);
    EXPECT_EQ(now.contact, hot) << "pair " << i;
    if (hot) {
      EXPECT_NEAR(narrow::norm(now.dir), 1.0, 1e-9) << "pair " << i;
    }
    if (cold != hot) {
      ++band;
      const double scale = narrow::pair_scale(a, b);
      EXPECT_LT(std::fabs(signed_distance(p.a, p.b)), 1e-7 * scale) << "pair " << i;
      EXPECT_LT(hot ? warm_hit.depth : cold_hit.depth, 1e-7 * scale) << "pair " << i;
      continue;
    }
    if (hot) {
      ++hits;
      EXPECT_NEAR(cold_hit.depth, warm_hit.depth, 2 * narrow::kContactDepthTolerance * cold_hit.depth + 1e-7);
    } else {
      ++misses;
    }
  }
  EXPECT_GT(hits, 100);
  EXPECT_GT(misses, 50);
  EXPECT_GT(fallbacks, 200) << "a cone around a random normal rarely encloses";
  EXPECT_LE(band, 4);
}

// Last frame's contact normal: the cone tetrahedron around it serves a good
// share of colliding pairs, with the cold path's verdict and depth; where
// it does not enclose, GJK goes on from it.
TEST(NarrowWarmTetrahedron, ConeTetrahedronAroundTheNormal) {
  ShapePairGenerator gen(5);
  int hits = 0, cone = 0, band = 0;
  for (int i = 0; i < 400; ++i) {
    const ShapePair p = gen.next(ShapeKind::Cylinder, ShapeKind::Cone);
    const narrow::Convex a = narrow::make_convex(p.a), b = narrow::make_convex(p.b);
    narrow::Hit cold_hit, warm_hit;
    const bool cold = narrow::intersect(a, b, &cold_hit, NarrowMethod::Auto);
    if (!cold) continue;
    narrow::Coherence warm;
    warm.dir = cold_hit.normal;
    warm.contact = true;
    narrow::Coherence now;
    const bool hot = narrow::intersect(a, b, &warm_hit, NarrowMethod::Auto, &warm, &now);
    if (!hot) {  // only inside the touching band
      ++band;
      EXPECT_LT(cold_hit.depth, 1e-7 * narrow::pair_scale(a, b)) << "pair " << i;
      continue;
    }
    ++hits;
    EXPECT_NEAR(cold_hit.depth, warm_hit.depth, 2 * narrow::kContactDepthTolerance * cold_hit.depth + 1e-7)
        << "pair " << i;
    cone += narrow::tetrahedron_encloses_origin(narrow::cone_tetrahedron(a, b, warm.dir));
  }
  EXPECT_GT(hits, 100);
  // (about a third here: on shallow contacts of curved shapes the three
  // tilted support points lie below the deepest one by more than the depth.)
  EXPECT_GT(cone, hits / 5) << "the cone encloses on a good share of the pairs";
  EXPECT_LT(cone, hits) << "and not on all";
  EXPECT_LE(band, 4);
}

// The pipeline with its cache (warm starts from the second frame on):
// the same contacts, bit for bit, on one or two threads.
TEST(NarrowWarmTetrahedron, PipelineSameContactsOnOneOrTwoThreads) {
  ScenarioParams p;
  p.n = 2000;
  p.seed = 11;
  Scenario scene(p);
  CollisionPipeline one({.engine = "sw", .cell_limit = 64, .threads = 1});
  CollisionPipeline two({.engine = "sw", .cell_limit = 64, .threads = 2});
  BoxArray boxes;
  for (int f = 0; f < 5; ++f) {
    if (f) scene.step();
    scene.compute_boxes(boxes);
    const std::vector<Contact> a = one.update(boxes, scene.shapes());
    const std::vector<Contact>& b = two.update(boxes, scene.shapes());
    ASSERT_GT(a.size(), 100u);
    ASSERT_EQ(a.size(), b.size()) << "frame " << f;
    for (std::size_t i = 0; i < a.size(); ++i) {
      ASSERT_EQ(a[i].a, b[i].a) << "frame " << f << " contact " << i;
      ASSERT_EQ(a[i].b, b[i].b) << "frame " << f << " contact " << i;
      ASSERT_EQ(a[i].depth, b[i].depth) << "frame " << f << " contact " << i;
      ASSERT_EQ(a[i].normal.x, b[i].normal.x) << "frame " << f << " contact " << i;
      ASSERT_EQ(a[i].point.z, b[i].point.z) << "frame " << f << " contact " << i;
    }
    // The after-frame tail is part of the frame's wall time.
    for (const CollisionPipeline* cp : {&one, &two}) {
      EXPECT_GT(cp->stats().tail_ms, 0.0) << "frame " << f;
      EXPECT_LT(cp->stats().tail_ms, cp->stats().wall_ms) << "frame " << f;
      EXPECT_GT(cp->stats().narrow_cpu_ms, 0.0) << "frame " << f;
    }
  }
}

// CollisionPipeline passes every broad-phase option through but `sorted`
// (its broad phase keeps cell order for the narrow phase).
TEST(CollisionPipelineOptions, EveryOptionButSortedReachesTheBroadPhase) {
  BroadPhaseOptions o;
  o.engine = "brute";
  o.cell_limit = 64;
  o.threads = 2;
  o.max_pairs = 12345;
  o.cost_splits = true;
  const CollisionPipeline pipeline(o);
  const BroadPhaseOptions& got = pipeline.broad_phase().options();
  EXPECT_EQ(got.engine, "brute");
  EXPECT_EQ(got.cell_limit, 64u);
  EXPECT_EQ(got.threads, 2u);
  EXPECT_EQ(got.max_pairs, 12345u);
  EXPECT_TRUE(got.cost_splits);
  EXPECT_FALSE(got.sorted);
}

}  // namespace
}  // namespace hbp

