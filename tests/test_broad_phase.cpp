// SPDX-License-Identifier: MIT
// hbp::BroadPhase against the brute-force reference of broad_phase_session.hpp:
// every live pair, minus static/static pairs, minus pairs whose layers do not
// collide or the pair filter rejects, on every frame of randomized edit
// sequences; events as the set difference with the previous frame; queries
// against a scan of every object. Plus stale handles, errors that change
// nothing, and 1 vs 2 threads.
#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <cstring>
#include <limits>
#include <map>
#include <set>
#include <random>
#include <span>
#include <vector>

#include "broad_phase_session.hpp"
#include "hbp/broad_phase.hpp"
#include "hbp/error.hpp"

namespace {

using hbp::Aabb;
using hbp::BroadPhase;
using hbp::Handle;
using hbp::Pair;

using hbp::test::minus;
using hbp::test::nudged;
using hbp::test::random_box;
using hbp::test::RefObject;
using hbp::test::Reference;
using hbp::test::same_box;

// The reference slab test: the segment o + t d, 0 <= t <= max_t, against the
// closed box; axes with d = 0 (or 1/d infinite) need o inside the slab.
bool ref_ray(const float o[3], const float d[3], float max_t, const Aabb& b, float& entry) {
  float t0 = 0, t1 = max_t;
  for (int k = 0; k < 3; ++k) {
    const float inv = 1.0f / d[k];
    if (d[k] == 0 || std::isinf(inv)) {
      if (o[k] < b.min[k] || o[k] > b.max[k]) return false;
      continue;
    }
    float a = (b.min[k] - o[k]) * inv, c = (b.max[k] - o[k]) * inv;
    if (a > c) std::swap(a, c);
    t0 = std::max(t0, a);
    t1 = std::min(t1, c);
  }
  if (!(t0 <= t1)) return false;
  entry = t0;
  return true;
}

// One broad phase on 1 thread and one on 2, driven alike beside the
// reference; update_and_check() compares both with it every frame.
struct ThreadTwins {
  BroadPhase one{{.threads = 1}}, two{{.threads = 2}};
  Reference ref;
  std::size_t changed = 0, pairs = 0;  // created + removed, and pairs, over all frames

  std::vector<Handle> add(const std::vector<Aabb>& boxes, bool is_static) {
    std::vector<Handle> h = one.add(boxes, {.is_static = is_static});
    EXPECT_EQ(two.add(boxes, {.is_static = is_static}), h);
    for (std::size_t i = 0; i < boxes.size(); ++i) ref.objects[h[i]] = {boxes[i], is_static, 0};
    return h;
  }
  void move(const std::vector<Handle>& h, const std::vector<Aabb>& boxes) {
    for (BroadPhase* s : {&one, &two}) s->move(h, boxes);
    for (std::size_t i = 0; i < h.size(); ++i) ref.objects[h[i]].box = boxes[i];
  }
  void remove(const std::vector<Handle>& h) {
    for (BroadPhase* s : {&one, &two}) s->remove(h);
    for (Handle x : h) ref.objects.erase(x);
  }
  void set_pair_filter(const BroadPhase::PairFilter& f) {
    for (BroadPhase* s : {&one, &two}) s->set_pair_filter(f);
    ref.filter = f;
  }
  void update_and_check(int frame) {
    const std::vector<Pair> want = ref.pairs();
    const std::vector<Pair> created = minus(want, ref.previous);
    const std::vector<Pair> removed = minus(ref.previous, want);
    changed += created.size() + removed.size();
    pairs += want.size();
    for (BroadPhase* s : {&one, &two}) {
      const hbp::BroadPhaseUpdate& u = s->update();
      ASSERT_EQ(u.pairs, want) << "frame " << frame;
      ASSERT_EQ(u.created, created) << "frame " << frame;
      ASSERT_EQ(u.removed, removed) << "frame " << frame;
    }
    ref.previous = want;
  }
};

// Every box and ray query of a handful, against a scan of the reference.
void check_queries(const BroadPhase& bp, const Reference& ref, std::mt19937& rng, const Aabb& probe, int count) {
  for (int q = 0; q < count; ++q) {
    Aabb query = probe;
    if (q > 0) {
      for (int k = 0; k < 3; ++k) {
        const float c = 0.5f * (probe.min[k] + probe.max[k]);
        const float r = static_cast<float>(rng() % 8);
        query.min[k] = std::isfinite(c - r) ? c - r : probe.min[k];
        query.max[k] = std::isfinite(c + r) ? c + r : probe.max[k];
      }
    }
    std::vector<Handle> want;
    for (const auto& [h, o] : ref.objects)
      if (hbp::overlaps(o.box, query)) want.push_back(h);
    ASSERT_EQ(bp.query_box(query), want) << "box query " << q;
    float o[3], d[3];
    for (int k = 0; k < 3; ++k) {
      o[k] = std::isfinite(query.min[k] - 3) ? query.min[k] - 3 : query.min[k];
      d[k] = static_cast<float>(static_cast<int>(rng() % 5) - 2);
    }
    const float max_t = q % 2 ? std::numeric_limits<float>::infinity() : 4.0f;
    struct Hit {
      float t;
      Handle h;
    };
    std::vector<Hit> hits;
    for (const auto& [h, obj] : ref.objects) {
      float t;
      if (ref_ray(o, d, max_t, obj.box, t)) hits.push_back({t, h});
    }
    std::sort(hits.begin(), hits.end(),
              [](const Hit& a, const Hit& b) { return a.t < b.t || (a.t == b.t && a.h < b.h); });
    std::vector<Handle> want_ray;
    for (const Hit& h : hits) want_ray.push_back(h.h);
    ASSERT_EQ(bp.query_ray(o, d, max_t), want_ray) << "ray query " << q;
  }
}

// One randomized session applied to a BroadPhase and the reference alike.
// With `queries`, every edit is followed by box and ray queries (which must
// see the edit and must not change what the next update() reports); with
// `wide`, one box in eight spans [-FLT_MAX, FLT_MAX] on an axis or reaches
// one end of the float range.
struct Session {
  std::mt19937 rng;
  float world;
  Reference ref;
  std::vector<BroadPhase*> systems;  // identical edits to each
  std::vector<Handle> live;
  bool queries = false, wide = false;

  Session(unsigned seed, float w, std::vector<BroadPhase*> s) : rng(seed), world(w), systems(std::move(s)) {}

  std::size_t pick() { return std::uniform_int_distribution<std::size_t>(0, live.size() - 1)(rng); }

  Aabb widened(Aabb b) {
    if (!wide || rng() % 8 != 0) return b;
    const float big = std::numeric_limits<float>::max();
    const int k = static_cast<int>(rng() % 3);
    switch (rng() % 3) {
      case 0:
        b.min[k] = -big;
        b.max[k] = big;
        break;
      case 1:
        b.max[k] = big;
        break;
      default:
        b.min[k] = -big;
        break;
    }
    return b;
  }

  void query_now() {
    if (!queries) return;
    Aabb probe = random_box(rng, world);
    if (!live.empty() && rng() % 2) probe = ref.objects[live[pick()]].box;  // an object's own box: a hit
    for (BroadPhase* s : systems) {
      check_queries(*s, ref, rng, probe, 3);
      if (testing::Test::HasFatalFailure()) return;
    }
  }

  void add(std::size_t n, bool is_static, std::uint8_t layer) {
    std::vector<Aabb> boxes(n);
    for (Aabb& b : boxes) b = widened(random_box(rng, world));
    std::vector<Handle> h;
    for (BroadPhase* s : systems) {
      auto got = s->add(boxes, {.is_static = is_static, .layer = layer});
      if (h.empty()) h = got;
      ASSERT_EQ(got, h) << "same edits, same handles";
    }
    for (std::size_t i = 0; i < n; ++i) {
      ASSERT_FALSE(ref.objects.count(h[i])) << "a live handle handed out twice";
      ref.objects[h[i]] = {boxes[i], is_static, layer};
      (is_static ? ref.static_changed : ref.moved).insert(h[i]);
      live.push_back(h[i]);
    }
    query_now();
  }

  // Moves a random subset (distinct handles): nudges, teleports and moves
  // to the box an object has; static objects only when asked (the fat-box
  // caches live while statics stay).
  void move(std::size_t n, bool statics_too) {
    std::vector<Handle> h;
    for (Handle x : live)
      if (statics_too || !ref.objects[x].is_static) h.push_back(x);
    if (h.empty()) return;
    std::shuffle(h.begin(), h.end(), rng);
    h.resize(std::min(n, h.size()));
    std::vector<Aabb> boxes;
    for (Handle x : h) {
      const unsigned kind = rng() % 10;
      const Aabb& now = ref.objects[x].box;
      boxes.push_back(kind == 0 ? widened(random_box(rng, world)) : kind == 1 ? now : nudged(rng, now));
    }
    for (BroadPhase* s : systems) s->move(h, boxes);
    for (std::size_t i = 0; i < h.size(); ++i) {
      RefObject& o = ref.objects[h[i]];
      if (!same_box(o.box, boxes[i])) (o.is_static ? ref.static_changed : ref.moved).insert(h[i]);
      o.box = boxes[i];
    }
    query_now();
  }

  void remove(std::size_t n) {
    std::shuffle(live.begin(), live.end(), rng);
    n = std::min(n, live.size());
    std::vector<Handle> h(live.end() - static_cast<std::ptrdiff_t>(n), live.end());
    live.resize(live.size() - n);
    for (BroadPhase* s : systems) s->remove(h);
    for (Handle x : h) {
      if (ref.objects[x].is_static) ref.static_changed.insert(x);
      ref.objects.erase(x);
    }
    query_now();
  }

  void set_layer(std::size_t n, std::uint8_t layer) {
    if (live.empty()) return;
    std::vector<Handle> h = live;
    std::shuffle(h.begin(), h.end(), rng);
    h.resize(std::min(n, h.size()));
    for (BroadPhase* s : systems) s->set_layer(h, layer);
    for (Handle x : h) ref.objects[x].layer = layer;
    query_now();
  }

  void set_collides(std::uint32_t a, std::uint32_t b, bool c) {
    for (BroadPhase* s : systems) s->set_collides(a, b, c);
    ref.set_collides(a, b, c);
  }

  void set_filter(BroadPhase::PairFilter f) {
    for (BroadPhase* s : systems) s->set_pair_filter(f);
    ref.filter = f;
  }

  // Updates every system and checks each against the reference: pairs,
  // events and the stats' counts.
  void check_frame(int frame) {
    const std::vector<Pair> want = ref.pairs();
    const std::vector<Pair> created = minus(want, ref.previous);
    const std::vector<Pair> removed = minus(ref.previous, want);
    for (std::size_t i = 0; i < systems.size(); ++i) {
      const hbp::BroadPhaseUpdate& u = systems[i]->update();
      ASSERT_EQ(u.pairs, want) << "system " << i << " frame " << frame;
      ASSERT_EQ(u.created, created) << "system " << i << " frame " << frame;
      ASSERT_EQ(u.removed, removed) << "system " << i << " frame " << frame;
      ASSERT_EQ(systems[i]->size(), ref.objects.size());
      ASSERT_EQ(systems[i]->stats().moved, ref.moved.size()) << "system " << i << " frame " << frame;
      ASSERT_EQ(systems[i]->stats().static_changes, ref.static_changed.size())
          << "system " << i << " frame " << frame;
    }
    ref.previous = want;
    ref.moved.clear();
    ref.static_changed.clear();
  }
};

void run_sequence(unsigned seed, int frames, std::size_t scale, float world, bool queries = false,
                  bool wide = false) {
  BroadPhase one({.threads = 1});
  BroadPhase two({.threads = 2});
  Session s(seed, world, {&one, &two});
  s.queries = queries;
  s.wide = wide;
  std::uint64_t pairs = 0, created = 0, removed = 0;
  s.add(scale, false, 0);
  s.add(scale, true, 1);
  for (int f = 0; f < frames; ++f) {
    const int op = f % 8;
    s.move(scale / 3, op == 7);
    if (op == 1) s.add(scale / 10 + 1, s.rng() % 2 == 0, static_cast<std::uint8_t>(s.rng() % 4));
    if (op == 2) s.remove(scale / 10 + 1);
    if (op == 3) s.set_layer(scale / 8, static_cast<std::uint8_t>(s.rng() % 4));
    if (op == 4) s.set_collides(s.rng() % 4, s.rng() % 4, false);
    if (op == 5) s.set_collides(s.rng() % 4, s.rng() % 4, true);
    if (op == 6) s.set_filter([](Handle a, Handle b) { return ((a ^ b) % 5) != 0; });
    if (op == 7 && f % 16 == 7) s.set_filter({});
    if (op == 0 && f % 16 == 8) {  // remove and re-add in one frame: slots reused
      s.remove(scale / 4);
      s.add(scale / 4, false, 2);
    }
    if (queries && f % 3 == 1) {  // statics added, moved and removed between a query and update()
      s.add(2, true, 0);
      s.move(scale / 10, true);
      s.remove(2);
    }
    s.check_frame(f);
    if (testing::Test::HasFatalFailure()) return;
    pairs += s.ref.previous.size();
    created += one.last_update().created.size();
    removed += one.last_update().removed.size();
  }
  // Not a vacuous run.
  EXPECT_GT(pairs, static_cast<std::uint64_t>(frames) * scale / 4);
  EXPECT_GT(created, 0u);
  EXPECT_GT(removed, 0u);
}

TEST(BroadPhase, RandomSequencesMatchBruteForce) {
  for (unsigned seed = 1; seed <= 4; ++seed) {
    SCOPED_TRACE(seed);
    run_sequence(seed, 40, 150, 20);
    if (HasFatalFailure()) return;
  }
}

// Enough objects for the parallel paths (several chunks of moving objects and
// of pairs) and a multi-cell partition.
TEST(BroadPhase, LargerSequenceMatchesBruteForce) { run_sequence(99, 6, 2500, 60); }

// Queries between every edit and the next update(): each sees the edits, and
// none changes what update() reports (a query synchronises the structures
// the update's incremental path is chosen by).
TEST(BroadPhase, RandomSequencesWithQueriesBetweenEditsMatchBruteForce) {
  for (unsigned seed = 11; seed <= 16; ++seed) {
    SCOPED_TRACE(seed);
    run_sequence(seed, 40, 120, 20, /*queries=*/true);
    if (HasFatalFailure()) return;
  }
  run_sequence(98, 8, 1500, 50, /*queries=*/true);
}

// The same with boxes that span the whole float range on an axis or reach
// one of its ends: the partition, the static tree and the refitted moving
// tree stay exact.
TEST(BroadPhase, RandomSequencesWithBoxesToFltMaxMatchBruteForce) {
  for (unsigned seed = 21; seed <= 24; ++seed) {
    SCOPED_TRACE(seed);
    run_sequence(seed, 32, 120, 20, /*queries=*/true, /*wide=*/true);
    if (HasFatalFailure()) return;
  }
}

TEST(BroadPhase, StaticStaticNeverReportedAndStaticsMove) {
  BroadPhase bp;
  const Aabb unit{{0, 0, 0}, {1, 1, 1}};
  const auto st = bp.add(std::vector<Aabb>{unit, unit}, {.is_static = true});
  EXPECT_TRUE(bp.update().pairs.empty());
  const auto mv = bp.add(std::vector<Aabb>{Aabb{{1, 1, 1}, {2, 2, 2}}});  // touches both at a corner
  auto u = bp.update();
  EXPECT_EQ(u.pairs, (std::vector<Pair>{{st[0], mv[0]}, {st[1], mv[0]}}));
  EXPECT_EQ(u.created, u.pairs);
  // A static object moves away: its pair is removed.
  bp.move(std::span<const Handle>(&st[1], 1), std::vector<Aabb>{Aabb{{5, 5, 5}, {6, 6, 6}}});
  u = bp.update();
  EXPECT_EQ(u.pairs, (std::vector<Pair>{{st[0], mv[0]}}));
  EXPECT_EQ(u.removed, (std::vector<Pair>{{st[1], mv[0]}}));
  EXPECT_TRUE(u.created.empty());
  EXPECT_TRUE(bp.is_static(st[0]));
  EXPECT_FALSE(bp.is_static(mv[0]));
  EXPECT_EQ(bp.stats().statics, 2u);
  EXPECT_EQ(bp.stats().moving, 1u);
  // Removing an object removes its pairs.
  bp.remove(mv);
  u = bp.update();
  EXPECT_TRUE(u.pairs.empty());
  EXPECT_EQ(u.removed, (std::vector<Pair>{{st[0], mv[0]}}));
}

// Moving boxes walking in quarter steps through a lattice of static unit
// boxes 1.5 apart: candidate pairs start and stop overlapping (and touch
// exactly at faces, edges and corners) inside the fat boxes, objects leave
// their quiet and fat boxes, and filters, layers and membership change in
// between, so the incremental moving/static pairs (flipped candidates merged
// into last frame's list) meet every fallback. 1 and 2 threads, every frame
// against the reference.
TEST(BroadPhase, CandidatesFlipInsideFatBoxes) {
  ThreadTwins twins;
  Reference& ref = twins.ref;
  const std::vector<BroadPhase*> systems{&twins.one, &twins.two};
  auto add = [&](const std::vector<Aabb>& boxes, bool is_static) { return twins.add(boxes, is_static); };
  std::vector<Aabb> statics;
  for (int x = 0; x < 6; ++x)
    for (int y = 0; y < 6; ++y)
      for (int z = 0; z < 3; ++z) {
        const float o[3] = {1.5f * x, 1.5f * y, 1.5f * z};
        statics.push_back({{o[0], o[1], o[2]}, {o[0] + 1, o[1] + 1, o[2] + 1}});
      }
  add(statics, true);
  std::mt19937 rng(7);
  std::vector<Aabb> boxes;
  for (int i = 0; i < 40; ++i) {
    const float x = 0.25f * static_cast<float>(rng() % 30), y = 0.25f * static_cast<float>(rng() % 30),
                z = 0.25f * static_cast<float>(rng() % 14);
    const float side = (i % 3 == 0) ? 0.5f : 1.0f;
    boxes.push_back({{x, y, z}, {x + side, y + side, z + side}});
  }
  std::vector<Handle> moving = add(boxes, false);
  for (int frame = 0; frame < 120; ++frame) {
    // Most objects step a quarter along one axis, a few teleport.
    std::vector<Aabb> moved(moving.size());
    for (std::size_t i = 0; i < moving.size(); ++i) {
      Aabb b = ref.objects[moving[i]].box;
      const int axis = static_cast<int>(rng() % 3);
      const float step = (rng() % 2 ? 0.25f : -0.25f) * (rng() % 8 == 0 ? 8.0f : 1.0f);
      b.min[axis] += step;
      b.max[axis] += step;
      if (rng() % 4 == 0) b = ref.objects[moving[i]].box;  // stays put
      moved[i] = b;
      ref.objects[moving[i]].box = b;
    }
    twins.move(moving, moved);
    if (frame == 40) twins.set_pair_filter([](Handle a, Handle b) { return (a + b) % 3 != 0; });  // for some frames
    if (frame == 50) twins.set_pair_filter({});
    if (frame == 60 || frame == 70) {  // layers that do not collide, then again
      const std::vector<Handle> some(moving.begin(), moving.begin() + 10);
      const std::uint8_t layer = frame == 60 ? 3 : 0;
      for (BroadPhase* s : systems) s->set_layer(some, layer);
      for (Handle h : some) ref.objects[h].layer = layer;
      for (BroadPhase* s : systems) s->set_collides(0, 3, frame != 60);
      ref.mask[0] = frame == 60 ? ~(1u << 3) : 0xFFFFFFFFu;
      ref.mask[3] = frame == 60 ? ~1u : 0xFFFFFFFFu;
    }
    if (frame == 80) {  // remove and re-add moving objects
      const std::vector<Handle> gone(moving.end() - 5, moving.end());
      std::vector<Aabb> back;
      for (Handle h : gone) back.push_back(ref.objects[h].box);
      twins.remove(gone);
      moving.resize(moving.size() - 5);
      const auto again = add(back, false);
      moving.insert(moving.end(), again.begin(), again.end());
    }
    ASSERT_NO_FATAL_FAILURE(twins.update_and_check(frame));
  }
  EXPECT_GT(twins.changed, 400u);  // the pairs really did start and stop
}

// Many moving objects among few statics (the mostly-static world's
// moving/moving path: fat-box candidates kept across frames): objects walk
// in quarter steps (a few leave their fat boxes each frame); statics change
// while the moving objects stay put; objects are removed and added with
// their slots reused across kinds (a moving object's slot to a static and
// back), so the dense per-object caches are reordered; a crowd gathers in
// one corner (too many candidates: the exact path for a while) and scatters;
// every object teleports for two frames (a rebuild, then the exact path).
// 1 and 2 threads, every frame against the reference.
TEST(BroadPhase, FewMovingObjectsEveryFallback) {
  ThreadTwins twins;
  Reference& ref = twins.ref;
  auto add = [&](const std::vector<Aabb>& boxes, bool is_static) { return twins.add(boxes, is_static); };
  auto move = [&](const std::vector<Handle>& h, const std::vector<Aabb>& boxes) { twins.move(h, boxes); };
  auto remove = [&](const std::vector<Handle>& h) { twins.remove(h); };
  std::mt19937 rng(11);
  const float world = 60;
  auto place = [&](float side) {
    const float x = 0.25f * static_cast<float>(rng() % static_cast<unsigned>(4 * world)),
                y = 0.25f * static_cast<float>(rng() % static_cast<unsigned>(4 * world)),
                z = 0.25f * static_cast<float>(rng() % static_cast<unsigned>(4 * world));
    return Aabb{{x, y, z}, {x + side, y + side, z + side}};
  };
  std::vector<Aabb> statics;
  for (int i = 0; i < 150; ++i) statics.push_back(place(static_cast<float>(1 + i % 4)));
  std::vector<Handle> fixed = add(statics, true);
  // More than 1024 moving objects: all of them teleporting is too many
  // re-tests for the fat path.
  std::vector<Aabb> boxes;
  for (int i = 0; i < 1100; ++i) boxes.push_back(place(i % 3 == 0 ? 0.5f : 2.0f));
  std::vector<Handle> moving = add(boxes, false);
  for (int frame = 0; frame < 70; ++frame) {
    std::vector<Aabb> moved(moving.size());
    for (std::size_t i = 0; i < moving.size(); ++i) {
      Aabb b = ref.objects[moving[i]].box;
      const float side = b.max[0] - b.min[0];
      if (frame == 60 || frame == 61 || (frame == 26 && i < 200)) {
        b = place(side);  // everybody teleports (26: the crowd scatters)
      } else if (frame == 25 && i < 200) {
        const float x = 0.25f * static_cast<float>(rng() % 8);
        b = {{x, x, x}, {x + side, x + side, x + side}};  // a crowd in one corner
      } else if (frame != 5) {  // frame 5: only statics change
        const int axis = static_cast<int>(rng() % 3);
        const float step = (rng() % 2 ? 0.25f : -0.25f) * (rng() % 16 == 0 ? 8.0f : 1.0f);
        b.min[axis] += step;
        b.max[axis] += step;
        if (rng() % 3 == 0) b = ref.objects[moving[i]].box;  // stays put
      }
      moved[i] = b;
    }
    move(moving, moved);
    if (frame == 5) {  // statics move and appear while the moving objects stay
      const std::vector<Handle> some(fixed.begin(), fixed.begin() + 10);
      std::vector<Aabb> to;
      for (std::size_t i = 0; i < some.size(); ++i) to.push_back(place(2));
      move(some, to);
      const auto more = add({place(3), place(1)}, true);
      fixed.insert(fixed.end(), more.begin(), more.end());
    }
    if (frame == 8) {  // a moving object's slot goes to a static, a static's to a moving object
      const Handle gone_static = fixed.back(), gone_moving = moving[7];
      remove({gone_static});
      remove({gone_moving});
      fixed.pop_back();
      moving.erase(moving.begin() + 7);
      const auto s = add({place(2)}, true);    // last freed first: gone_moving's slot
      const auto m = add({place(2)}, false);  // gone_static's slot
      EXPECT_EQ(s[0] & 0xFFFFFFu, gone_moving & 0xFFFFFFu);
      EXPECT_EQ(m[0] & 0xFFFFFFu, gone_static & 0xFFFFFFu);
      fixed.push_back(s[0]);
      moving.push_back(m[0]);
    }
    if (frame == 12 || frame == 64) {  // remove some, then add as many in the same frame
      std::vector<Handle> gone(moving.begin() + 100, moving.begin() + 140);
      std::vector<Aabb> back;
      for (Handle h : gone) back.push_back(ref.objects[h].box);
      remove(gone);
      moving.erase(moving.begin() + 100, moving.begin() + 140);
      const auto again = add(back, false);
      moving.insert(moving.end(), again.begin(), again.end());
    }
    ASSERT_NO_FATAL_FAILURE(twins.update_and_check(frame));
  }
  EXPECT_GT(twins.pairs, 70u * 50);
  EXPECT_GT(twins.changed, 1000u);
}

// max_pairs counts exact moving/moving pairs, not fat candidates.
TEST(BroadPhase, MaxPairsCountsExactPairsWhenFewMove) {
  BroadPhase bp({.threads = 1, .max_pairs = 1});
  // a and b touch; c is near both (their fat boxes overlap) but touches neither.
  const auto h = bp.add(std::vector<Aabb>{Aabb{{0, 0, 0}, {1, 1, 1}}, Aabb{{1, 0, 0}, {2, 1, 1}},
                                          Aabb{{2.25f, 0, 0}, {3.25f, 1, 1}}});
  for (int frame = 0; frame < 40; ++frame) {
    const float d = 0.001f * static_cast<float>(frame % 2);
    bp.move(std::span<const Handle>(&h[2], 1), std::vector<Aabb>{Aabb{{2.25f + d, 0, 0}, {3.25f + d, 1, 1}}});
    EXPECT_EQ(bp.update().pairs, (std::vector<Pair>{{h[0], h[1]}})) << "frame " << frame;
  }
  bp.move(std::span<const Handle>(&h[2], 1), std::vector<Aabb>{Aabb{{2, 0, 0}, {3, 1, 1}}});  // touches b
  EXPECT_THROW(bp.update(), hbp::CapacityExceeded);
  EXPECT_EQ(bp.last_update().pairs, (std::vector<Pair>{{h[0], h[1]}}));
}

TEST(BroadPhase, StaleHandlesRejected) {
  BroadPhase bp;
  const Aabb b{{0, 0, 0}, {1, 1, 1}};
  const auto first = bp.add(std::vector<Aabb>{b, b});
  bp.remove(std::span<const Handle>(&first[0], 1));
  const auto second = bp.add(std::vector<Aabb>{b});  // reuses the slot
  EXPECT_EQ(second[0] & 0xFFFFFFu, first[0] & 0xFFFFFFu) << "slot reused";
  EXPECT_NE(second[0], first[0]) << "with a new generation";
  EXPECT_FALSE(bp.contains(first[0]));
  EXPECT_TRUE(bp.contains(second[0]));
  const Handle stale = first[0];
  const Aabb far{{9, 9, 9}, {10, 10, 10}};
  EXPECT_THROW(bp.move(std::span<const Handle>(&stale, 1), std::span<const Aabb>(&far, 1)), hbp::InvalidInput);
  EXPECT_THROW(bp.remove(std::span<const Handle>(&stale, 1)), hbp::InvalidInput);
  EXPECT_THROW(bp.set_layer(std::span<const Handle>(&stale, 1), 3), hbp::InvalidInput);
  EXPECT_THROW(bp.box(stale), hbp::InvalidInput);
  EXPECT_THROW(bp.layer(stale), hbp::InvalidInput);
  EXPECT_THROW(bp.is_static(stale), hbp::InvalidInput);
  try {
    bp.move(std::span<const Handle>(&stale, 1), std::span<const Aabb>(&far, 1));
  } catch (const hbp::InvalidInput& e) {
    EXPECT_NE(std::string(e.what()).find("stale"), std::string::npos) << e.what();
    EXPECT_NE(std::string(e.what()).find("row 0"), std::string::npos) << e.what();
  }
  // The live object in that slot was not touched.
  EXPECT_EQ(bp.box(second[0]).max[0], 1.0f);
  EXPECT_EQ(bp.update().pairs, (std::vector<Pair>{hbp::make_pair(first[1], second[0])}));
  // Unknown handles too.
  const Handle unknown = 12345;
  EXPECT_THROW(bp.remove(std::span<const Handle>(&unknown, 1)), hbp::InvalidInput);
  EXPECT_THROW(bp.box(hbp::kInvalidHandle), hbp::InvalidInput);
}

// Every error leaves the broad phase exactly as a twin that never saw the call.
TEST(BroadPhase, ErrorsChangeNothing) {
  BroadPhase bp, twin;
  std::mt19937 rng(5);
  std::vector<Aabb> boxes(40);
  for (Aabb& b : boxes) b = random_box(rng, 8);
  const auto h = bp.add(boxes);
  twin.add(boxes);
  const auto hs = bp.add(std::span<const Aabb>(boxes).first(10), {.is_static = true, .layer = 1});
  twin.add(std::span<const Aabb>(boxes).first(10), {.is_static = true, .layer = 1});
  bp.update();
  twin.update();
  bp.remove(std::span<const Handle>(&h[39], 1));
  twin.remove(std::span<const Handle>(&h[39], 1));
  const float nan = std::numeric_limits<float>::quiet_NaN(), inf = std::numeric_limits<float>::infinity();

  std::vector<Aabb> bad = {boxes[0], boxes[1], boxes[2]};
  auto expect_row = [](auto&& call, const char* text) {
    try {
      call();
      ADD_FAILURE() << "no throw, expected " << text;
    } catch (const hbp::InvalidInput& e) {
      EXPECT_NE(std::string(e.what()).find(text), std::string::npos) << e.what();
    }
  };
  bad[2].min[1] = nan;
  expect_row([&] { bp.add(bad); }, "row 2");
  expect_row([&] { bp.move(std::span<const Handle>(h).first(3), bad); }, "row 2");
  bad[2] = boxes[2];
  bad[1].max[0] = inf;
  expect_row([&] { bp.add(bad); }, "row 1");
  bad[1] = boxes[1];
  bad[0].min[2] = bad[0].max[2] + 1;
  expect_row([&] { bp.add(bad, {.is_static = true}); }, "row 0");
  expect_row([&] { bp.add(boxes, {.layer = 32}); }, "layer 32");
  const std::vector<Handle> dup = {h[0], h[1], h[0]};
  expect_row([&] { bp.move(dup, std::span<const Aabb>(boxes).first(3)); }, "row 2");
  expect_row([&] { bp.remove(dup); }, "repeats row 0");
  expect_row([&] { bp.set_layer(dup, 2); }, "row 2");
  const std::vector<Handle> stale = {h[0], h[39]};
  expect_row([&] { bp.remove(stale); }, "row 1");
  expect_row([&] { bp.move(stale, std::span<const Aabb>(boxes).first(2)); }, "stale");
  expect_row([&] { bp.move(stale, std::span<const Aabb>(boxes).first(3)); }, "2 handles but 3 boxes");
  expect_row([&] { bp.set_layer(std::span<const Handle>(h).first(2), 32); }, "layer 32");
  expect_row([&] { bp.set_collides(0, 32, false); }, "layer 32");
  // Past the object limit: refused before a box is read.
  expect_row([&] { bp.add(std::span<const Aabb>(boxes.data(), hbp::kMaxObjects)); }, "limit");
  expect_row([&] { bp.reserve(std::size_t{hbp::kMaxObjects} + 1); }, "limit");
  const float o[3] = {0, 0, 0}, d[3] = {1, 0, 0}, dn[3] = {nan, 0, 0};
  expect_row([&] { bp.query_ray(o, dn, 1); }, "direction[0]");
  expect_row([&] { bp.query_ray(o, d, -1); }, "max_t");
  expect_row([&] { bp.query_ray(o, d, nan); }, "max_t");
  Aabb inverted{{1, 0, 0}, {0, 1, 1}};
  expect_row([&] { bp.query_box(inverted); }, "min > max");

  EXPECT_EQ(bp.size(), twin.size());
  const auto& a = bp.update();
  const auto& b = twin.update();
  EXPECT_EQ(a.pairs, b.pairs);
  EXPECT_EQ(a.created, b.created);
  EXPECT_EQ(a.removed, b.removed);
  EXPECT_FALSE(a.pairs.empty());
  for (Handle x : h)
    if (x != h[39]) {
      EXPECT_EQ(bp.layer(x), 0);
      const Aabb ba = bp.box(x), bb = twin.box(x);
      EXPECT_EQ(std::memcmp(&ba, &bb, sizeof(Aabb)), 0);
    }
  for (Handle x : hs) EXPECT_EQ(bp.layer(x), 1);
  EXPECT_TRUE(bp.collides(0, 31));
}

TEST(BroadPhase, QueriesMatchBruteForce) {
  std::mt19937 rng(17);
  BroadPhase bp({.threads = 2});
  std::vector<Aabb> boxes(900);
  for (Aabb& b : boxes) b = random_box(rng, 30);
  const auto hm = bp.add(std::span<const Aabb>(boxes).first(300));
  const auto hs = bp.add(std::span<const Aabb>(boxes).subspan(300), {.is_static = true, .layer = 3});
  std::vector<Handle> handles = hm;
  handles.insert(handles.end(), hs.begin(), hs.end());
  std::vector<Aabb> now = boxes;

  std::uint64_t box_hits = 0, ray_hits = 0, inside_hits = 0;
  for (int round = 0; round < 3; ++round) {
    // Queries between edits see the edits (no update needed).
    if (round > 0) {
      std::vector<Aabb> moved;
      for (std::size_t i = 0; i < 300; ++i) moved.push_back(now[i] = nudged(rng, now[i]));
      bp.move(hm, moved);
    }
    if (round == 2) bp.update();
    for (int q = 0; q < 150; ++q) {
      Aabb query = random_box(rng, 30);
      if (q % 3 == 0) {  // exactly touching an object's max corner
        const Aabb& o = now[rng() % now.size()];
        query = {{o.max[0], o.max[1], o.max[2]}, {o.max[0] + 1, o.max[1] + 1, o.max[2] + 1}};
      }
      std::vector<Handle> want;
      for (std::size_t i = 0; i < now.size(); ++i)
        if (hbp::overlaps(now[i], query)) want.push_back(handles[i]);
      std::sort(want.begin(), want.end());
      ASSERT_EQ(bp.query_box(query), want) << "box query " << q;
      box_hits += want.size();
      if (q % 3 == 0) {
        ASSERT_FALSE(want.empty());
      }

      // Rays of every kind.
      std::uniform_real_distribution<float> u(-2, 32);
      float o[3] = {u(rng), u(rng), u(rng)}, d[3] = {u(rng) - 15, u(rng) - 15, u(rng) - 15};
      float max_t = std::uniform_real_distribution<float>(0, 3)(rng);
      switch (q % 6) {
        case 1:  // axis-parallel
          d[0] = d[1] = 0;
          break;
        case 2:  // from inside a box
        {
          const Aabb& b = now[rng() % now.size()];
          for (int k = 0; k < 3; ++k) o[k] = 0.5f * (b.min[k] + b.max[k]);
          break;
        }
        case 3:  // grazing: along a face plane, axis-parallel
        {
          const Aabb& b = now[rng() % now.size()];
          o[0] = b.min[0] - 5;
          o[1] = b.max[1];
          o[2] = b.min[2];
          d[0] = 1;
          d[1] = d[2] = 0;
          max_t = 40;
          break;
        }
        case 4:
          max_t = 0;
          break;
        case 5:
          max_t = std::numeric_limits<float>::infinity();
          break;
        default:
          break;
      }
      struct Hit {
        float t;
        Handle h;
      };
      std::vector<Hit> hits;
      for (std::size_t i = 0; i < now.size(); ++i) {
        float t;
        if (ref_ray(o, d, max_t, now[i], t)) hits.push_back({t, handles[i]});
      }
      std::sort(hits.begin(), hits.end(),
                [](const Hit& a, const Hit& b) { return a.t < b.t || (a.t == b.t && a.h < b.h); });
      std::vector<Handle> want_ray;
      for (const Hit& h : hits) want_ray.push_back(h.h);
      ASSERT_EQ(bp.query_ray(o, d, max_t), want_ray) << "ray " << q;
      ray_hits += want_ray.size();
      if (q % 6 == 2 || q % 6 == 3) {
        ASSERT_FALSE(want_ray.empty()) << "ray " << q;
        inside_hits += want_ray.size();
      }
    }
  }
  EXPECT_GT(box_hits, 450u);
  EXPECT_GT(ray_hits, 450u);
  EXPECT_GT(inside_hits, 0u);
}

// ---- the all-moving frame (every object moving, no filter) -----------------

// Exact pairs by sort and sweep on x, written here (the O(n^2) reference is
// too slow for the tens of thousands of objects the parallel paths need).
std::vector<Pair> sweep_pairs(const std::map<Handle, Aabb>& objects) {
  std::vector<std::pair<Handle, Aabb>> v(objects.begin(), objects.end());
  std::sort(v.begin(), v.end(), [](const auto& a, const auto& b) { return a.second.min[0] < b.second.min[0]; });
  std::vector<Pair> out;
  for (std::size_t i = 0; i < v.size(); ++i)
    for (std::size_t j = i + 1; j < v.size() && v[j].second.min[0] <= v[i].second.max[0]; ++j)
      if (hbp::overlaps(v[i].second, v[j].second)) out.push_back(hbp::make_pair(v[i].first, v[j].first));
  std::sort(out.begin(), out.end());
  return out;
}

// Enough objects that move() of a whole batch runs in parallel ranges
// (>= 32768) and a frame's pairs span several merge ranges (>= 16384 each),
// in a world long in x so that the reference's sweep stays short.
constexpr std::size_t kManyObjects = 36000;
constexpr float kManyLength = 2000, kManyWidth = 12;

Aabb long_world_box(std::mt19937& rng) {
  Aabb b = random_box(rng, kManyWidth);
  const float x = 0.5f * static_cast<float>(std::uniform_int_distribution<int>(0, 2 * kManyLength)(rng));
  b.max[0] += x - b.min[0];
  b.min[0] = x;
  return b;
}

struct AllMovingWorld {
  std::mt19937 rng{23};
  std::map<Handle, Aabb> objects;
  std::vector<Pair> previous;
  BroadPhase one{{.threads = 1}}, two{{.threads = 2}};

  std::vector<Handle> add(std::size_t n) {
    std::vector<Aabb> boxes(n);
    for (Aabb& b : boxes) b = long_world_box(rng);
    const auto h = one.add(boxes);
    EXPECT_EQ(two.add(boxes), h);
    for (std::size_t i = 0; i < n; ++i) objects[h[i]] = boxes[i];
    return h;
  }

  // Moves `handles` (in the given order): nudges and a few teleports.
  void move(const std::vector<Handle>& handles) {
    std::vector<Aabb> boxes;
    for (Handle x : handles) boxes.push_back(rng() % 20 == 0 ? long_world_box(rng) : nudged(rng, objects[x]));
    one.move(handles, boxes);
    two.move(handles, boxes);
    for (std::size_t i = 0; i < handles.size(); ++i) objects[handles[i]] = boxes[i];
  }

  std::vector<Handle> all() const {
    std::vector<Handle> h;
    for (const auto& [x, b] : objects) h.push_back(x);
    return h;  // ascending: handle order
  }

  // Checks one frame; returns the frame's pair count.
  std::size_t check(int frame, std::vector<Pair> want = {}, bool given = false) {
    if (!given) want = sweep_pairs(objects);
    const auto created = minus(want, previous), removed = minus(previous, want);
    for (BroadPhase* bp : {&one, &two}) {
      const hbp::BroadPhaseUpdate& u = bp->update();
      EXPECT_EQ(u.pairs, want) << "frame " << frame << (bp == &one ? " (1 thread)" : " (2 threads)");
      EXPECT_EQ(u.created, created) << "frame " << frame;
      EXPECT_EQ(u.removed, removed) << "frame " << frame;
    }
    previous = want;
    return want.size();
  }
};

TEST(BroadPhase, AllMovingFramesMatchReference) {
  AllMovingWorld w;
  w.two.reserve(kManyObjects);  // provisions memory only: the same results as `one`'s
  w.add(kManyObjects);
  std::size_t min_pairs = ~std::size_t(0);
  std::uint64_t created = 0;
  for (int frame = 0; frame < 8; ++frame) {
    const std::vector<Handle> all = w.all();
    switch (frame) {
      case 1: {  // an increasing subset: the general move() with its screen
        std::vector<Handle> some;
        for (std::size_t i = 0; i < all.size(); i += 3) some.push_back(all[i]);
        w.move(some);
        break;
      }
      case 2: {  // removed and re-added: reused slots, new generations, so
                 // handles are no longer dense indices (the mapped merge)
        std::vector<Handle> gone;
        for (std::size_t i = 0; i < all.size(); i += 7) gone.push_back(all[i]);
        w.one.remove(gone);
        w.two.remove(gone);
        for (Handle x : gone) w.objects.erase(x);
        w.add(gone.size() / 2);
        break;
      }
      case 4: {  // a filtered frame (general path) between all-moving ones
        std::vector<Handle> some(all.begin(), all.begin() + 5000);
        w.one.set_layer(some, 1);
        w.two.set_layer(some, 1);
        w.one.set_collides(0, 1, false);
        w.two.set_collides(0, 1, false);
        w.move(all);
        // Layer 1 (`some`, sorted) no longer meets layer 0.
        auto in_some = [&](Handle x) { return std::binary_search(some.begin(), some.end(), x); };
        std::vector<Pair> want;
        for (const Pair p : sweep_pairs(w.objects))
          if (in_some(p.a) == in_some(p.b)) want.push_back(p);
        min_pairs = std::min(min_pairs, w.check(frame, want, true));
        w.one.set_collides(0, 1, true);
        w.two.set_collides(0, 1, true);
        continue;
      }
      case 6: {  // a static object present: not the all-moving frame
        const Aabb wall{{0, 0, 0}, {kManyLength, kManyWidth, 1}};
        const auto s1 = w.one.add(std::span<const Aabb>(&wall, 1), {.is_static = true});
        const auto s2 = w.two.add(std::span<const Aabb>(&wall, 1), {.is_static = true});
        ASSERT_EQ(s1, s2);
        w.move(all);
        w.objects[s1[0]] = wall;
        std::vector<Pair> want = sweep_pairs(w.objects);
        min_pairs = std::min(min_pairs, w.check(frame, want, true));
        w.one.remove(s1);
        w.two.remove(s1);
        w.objects.erase(s1[0]);
        continue;
      }
      default:  // every object in handle order: the one-pass move()
        w.move(all);
    }
    min_pairs = std::min(min_pairs, w.check(frame));
    created += w.one.last_update().created.size();
    if (HasFailure()) return;
  }
  EXPECT_GT(min_pairs, 2u * 16384u) << "several merge ranges per frame";
  EXPECT_GT(created, 1000u);
  // Boxes read back as last moved (moving boxes live in the dense arrays).
  for (const auto& [x, b] : w.objects) {
    const Aabb got = w.two.box(x);
    ASSERT_EQ(std::memcmp(&got, &b, sizeof(Aabb)), 0) << "handle " << x;
  }
}

// The one-pass move() of every object refuses a bad batch like the
// row-by-row checks: same messages, nothing changed.
TEST(BroadPhase, WholeBatchMoveErrorsChangeNothing) {
  AllMovingWorld w;
  const auto h = w.add(kManyObjects);
  w.check(0);
  const std::vector<Handle> all = w.all();
  std::vector<Aabb> boxes;
  for (Handle x : all) boxes.push_back(nudged(w.rng, w.objects[x]));
  auto expect_row = [&](const std::vector<Handle>& handles, const std::vector<Aabb>& b, const char* text) {
    try {
      w.one.move(handles, b);
      ADD_FAILURE() << "no throw, expected " << text;
    } catch (const hbp::InvalidInput& e) {
      EXPECT_NE(std::string(e.what()).find(text), std::string::npos) << e.what();
    }
  };
  const float nan = std::numeric_limits<float>::quiet_NaN(), inf = std::numeric_limits<float>::infinity();
  std::vector<Aabb> bad = boxes;
  bad.back().max[1] = nan;
  expect_row(all, bad, "row 35999: NaN");
  bad.back() = boxes.back();
  bad[30000].min[2] = bad[30000].max[2] + 1;
  expect_row(all, bad, "row 30000: min > max");
  bad[30000] = boxes[30000];
  bad[17].min[0] = -inf;
  expect_row(all, bad, "row 17: infinite");
  std::vector<Handle> dup = all;
  dup[20001] = dup[20000];
  expect_row(dup, boxes, "row 20001");
  std::vector<Handle> unknown = all;
  unknown[33333] = 0xFFFFFFu;
  expect_row(unknown, boxes, "row 33333: unknown");
  // An increasing subset (the general move's screen), bad late row.
  std::vector<Handle> some(all.begin(), all.begin() + 34000);
  std::vector<Aabb> some_boxes(boxes.begin(), boxes.begin() + 34000);
  some_boxes[33999].max[0] = inf;
  expect_row(some, some_boxes, "row 33999: infinite");
  // Nothing changed: `one` still agrees with the reference (and `two`).
  for (std::size_t i = 0; i < all.size(); i += 97) {
    const Aabb got = w.one.box(all[i]), want = w.objects[all[i]];
    ASSERT_EQ(std::memcmp(&got, &want, sizeof(Aabb)), 0) << "row " << i;
  }
  w.check(1);
  // And the good batch then goes through.
  w.one.move(all, boxes);
  w.two.move(all, boxes);
  for (std::size_t i = 0; i < all.size(); ++i) w.objects[all[i]] = boxes[i];
  w.check(2);
  EXPECT_EQ(h.size(), all.size());
}

// A whole batch of 2^18 or more boxes is written with non-temporal stores:
// update() sees exactly the moved boxes (the pairs of the whole-frame path
// on the same boxes, events as the set differences), and a bad last row
// still changes nothing.
TEST(BroadPhase, LargeWholeBatchMoveStreamsAndMatchesWholeFrame) {
  constexpr std::size_t n = 270000;  // above move()'s streaming threshold (2^18)
  std::mt19937 rng(41);
  std::uniform_real_distribution<float> jitter(-0.4f, 0.4f);
  // A sparse lattice of unit boxes (spacing 1.6): jitter makes a few pairs.
  auto frame_boxes = [&] {
    std::vector<Aabb> b(n);
    for (std::size_t i = 0; i < n; ++i) {
      const float x = 1.6f * static_cast<float>(i % 100), y = 1.6f * static_cast<float>((i / 100) % 100),
                  z = 1.6f * static_cast<float>(i / 10000);
      const float c[3] = {x + jitter(rng), y + jitter(rng), z + jitter(rng)};
      for (int k = 0; k < 3; ++k) {
        b[i].min[k] = c[k];
        b[i].max[k] = c[k] + 1.0f;
      }
    }
    return b;
  };
  auto whole_frame = [&](hbp::HybridBroadPhase& whole, const std::vector<Aabb>& b) {
    hbp::BoxArray arr(b.size());
    for (std::size_t i = 0; i < b.size(); ++i) arr.set(i, b[i]);
    return whole.update(arr);
  };
  BroadPhase bp({.threads = 2});
  hbp::HybridBroadPhase whole({.threads = 2});
  std::vector<Aabb> boxes = frame_boxes();
  const std::vector<Handle> h = bp.add(boxes);
  std::vector<Pair> previous = whole_frame(whole, boxes);
  ASSERT_EQ(bp.update().pairs, previous);
  boxes = frame_boxes();
  bp.move(h, boxes);
  {
    const std::vector<Pair> want = whole_frame(whole, boxes);
    const hbp::BroadPhaseUpdate& u = bp.update();
    ASSERT_EQ(u.pairs, want);
    EXPECT_EQ(u.created, minus(want, previous));
    EXPECT_EQ(u.removed, minus(previous, want));
    EXPECT_GT(want.size(), 1000u);
    EXPECT_GT(u.created.size(), 1000u);
    EXPECT_GT(u.removed.size(), 1000u);
    previous = want;
  }
  // A bad last row: refused with the row checks' message, nothing changed.
  std::vector<Aabb> bad = frame_boxes();
  bad[n - 1].max[2] = std::numeric_limits<float>::quiet_NaN();
  try {
    bp.move(h, bad);
    ADD_FAILURE() << "no throw";
  } catch (const hbp::InvalidInput& e) {
    EXPECT_NE(std::string(e.what()).find("row 269999: NaN"), std::string::npos) << e.what();
  }
  for (std::size_t i = 0; i < n; i += 997) {
    const Aabb got = bp.box(h[i]);
    ASSERT_EQ(std::memcmp(&got, &boxes[i], sizeof(Aabb)), 0) << "row " << i;
  }
  const hbp::BroadPhaseUpdate& u = bp.update();
  EXPECT_EQ(u.pairs, previous);
  EXPECT_TRUE(u.created.empty());
  EXPECT_TRUE(u.removed.empty());
}

TEST(BroadPhase, EmptyAndSingle) {
  BroadPhase bp;
  EXPECT_TRUE(bp.update().pairs.empty());
  const float o[3] = {0, 0, 0}, d[3] = {1, 1, 1};
  EXPECT_TRUE(bp.query_ray(o, d, 10).empty());
  EXPECT_TRUE(bp.query_box(Aabb{{0, 0, 0}, {1, 1, 1}}).empty());
  const auto h = bp.add(std::vector<Aabb>{Aabb{{0, 0, 0}, {1, 1, 1}}});
  EXPECT_TRUE(bp.update().pairs.empty());
  EXPECT_EQ(bp.query_ray(o, d, 10), h);
  bp.remove(h);
  EXPECT_TRUE(bp.query_ray(o, d, 10).empty());
  EXPECT_EQ(bp.size(), 0u);
}

}  // namespace

// ---- hardening: queries between edits and update(), refits, filters, stats --

namespace {

constexpr Aabb kUnit{{0, 0, 0}, {1, 1, 1}};

Aabb shifted(const Aabb& b, float dx) { return {{b.min[0] + dx, b.min[1], b.min[2]}, {b.max[0] + dx, b.max[1], b.max[2]}}; }

// Runs each kind of query: what a query sees must not change update().
void query_once(const BroadPhase& bp, int kind) {
  const float o[3] = {-100, 0.5f, 0.5f}, d[3] = {1, 0, 0};
  if (kind == 0) (void)bp.query_box(Aabb{{-100, -100, -100}, {100, 100, 100}});
  if (kind == 1) (void)bp.query_ray(o, d, std::numeric_limits<float>::infinity());
}

// A world whose moving objects have settled (quiet boxes set: the update's
// incremental path skips them), before each of the edits.
struct Settled {
  BroadPhase bp{{.threads = 2}};
  std::vector<Handle> movers, statics;
  Settled() {
    std::vector<Aabb> m, s;
    for (int i = 0; i < 6; ++i) m.push_back(shifted(kUnit, 10.0f * static_cast<float>(i)));
    movers = bp.add(m);
    s.push_back(shifted(kUnit, 0.5f));  // overlaps mover 0
    statics = bp.add(s, {.is_static = true});
    for (int f = 0; f < 3; ++f) {
      bp.move(movers, m);  // the same boxes: quiet
      bp.update();
    }
    EXPECT_EQ(bp.last_update().pairs, (std::vector<Pair>{{movers[0], statics[0]}}));
  }
};

}  // namespace

TEST(BroadPhase, QueryBetweenStaticEditAndUpdateKeepsTheEdit) {
  for (int kind = 0; kind < 2; ++kind) {
    SCOPED_TRACE(kind);
    {  // a new static beside a quiet mover
      Settled w;
      const Aabb near_mover2 = shifted(kUnit, 20.5f);
      const Handle added = w.bp.add(std::span<const Aabb>(&near_mover2, 1), {.is_static = true})[0];
      query_once(w.bp, kind);
      const hbp::BroadPhaseUpdate& u = w.bp.update();
      EXPECT_EQ(u.created, (std::vector<Pair>{{w.movers[2], added}}));
      EXPECT_TRUE(u.removed.empty());
      EXPECT_EQ(w.bp.stats().static_changes, 1u);
    }
    {  // a static moved from mover 0 to mover 3
      Settled w;
      const Aabb near_mover3 = shifted(kUnit, 30.5f);
      w.bp.move(w.statics, std::span<const Aabb>(&near_mover3, 1));
      query_once(w.bp, kind);
      const hbp::BroadPhaseUpdate& u = w.bp.update();
      EXPECT_EQ(u.created, (std::vector<Pair>{{w.movers[3], w.statics[0]}}));
      EXPECT_EQ(u.removed, (std::vector<Pair>{{w.movers[0], w.statics[0]}}));
      EXPECT_EQ(u.pairs, (std::vector<Pair>{{w.movers[3], w.statics[0]}}));
    }
    {  // a removed static
      Settled w;
      w.bp.remove(w.statics);
      query_once(w.bp, kind);
      EXPECT_EQ(w.bp.update().removed, (std::vector<Pair>{{w.movers[0], w.statics[0]}}));
      EXPECT_TRUE(w.bp.last_update().pairs.empty());
    }
  }
}

TEST(BroadPhase, QueryBetweenMovingRemoveAndUpdateKeepsTheEdit) {
  for (int kind = 0; kind < 2; ++kind) {
    SCOPED_TRACE(kind);
    Settled w;
    w.bp.remove(std::span<const Handle>(&w.movers[0], 1));
    query_once(w.bp, kind);
    EXPECT_EQ(w.bp.update().removed, (std::vector<Pair>{{w.movers[0], w.statics[0]}}));
    EXPECT_TRUE(w.bp.last_update().pairs.empty());
    for (int f = 0; f < 3; ++f) {  // the removed handle is never reported again
      query_once(w.bp, kind);
      const hbp::BroadPhaseUpdate& u = w.bp.update();
      EXPECT_TRUE(u.pairs.empty() && u.created.empty() && u.removed.empty()) << "frame " << f;
    }
  }
}

// Moving boxes that span [-FLT_MAX, FLT_MAX] on one axis: the queries stay
// exact after the moving objects' query tree is refitted (unchanged boxes,
// then moved ones).
TEST(BroadPhase, QueriesExactAfterRefitOfBoxesSpanningTheFloatRange) {
  const float big = std::numeric_limits<float>::max();
  for (int axis = 0; axis < 3; ++axis) {
    SCOPED_TRACE(axis);
    BroadPhase bp({.threads = 2});
    std::vector<Aabb> boxes;
    for (int i = 0; i < 300; ++i) {
      Aabb b = shifted(kUnit, 3.0f * static_cast<float>(i % 30));
      b.min[(axis + 1) % 3] += static_cast<float>(3 * (i / 30));
      b.max[(axis + 1) % 3] += static_cast<float>(3 * (i / 30));
      if (i % 2 == 0) {
        b.min[axis] = -big;
        b.max[axis] = big;
      }
      boxes.push_back(b);
    }
    const std::vector<Handle> h = bp.add(boxes);
    const auto expect_all = [&](const char* when) {
      const std::vector<Handle> got = bp.query_box(Aabb{{-big, -big, -big}, {big, big, big}});
      EXPECT_EQ(got, h) << when;
      const float o[3] = {0, 0, 0};
      float d[3] = {0, 0, 0};
      d[axis] = 1;
      const Aabb& first = boxes[0];  // spans the axis: a ray along it from inside starts in it
      float inside[3] = {0.5f * (first.min[0] + first.max[0]), 0.5f * (first.min[1] + first.max[1]),
                         0.5f * (first.min[2] + first.max[2])};
      inside[axis] = 0;
      (void)o;
      const std::vector<Handle> hits = bp.query_ray(inside, d, 1.0f);
      EXPECT_NE(std::find(hits.begin(), hits.end(), h[0]), hits.end()) << when;
    };
    bp.update();
    expect_all("after the build");
    bp.move(h, boxes);
    bp.update();
    expect_all("after a refit with the same boxes");
    for (Aabb& b : boxes) b = shifted(b, 0.25f);
    bp.move(h, boxes);
    expect_all("after a refit with moved boxes");
  }
}

// A pair filter that throws: the exception propagates, nothing of the frame
// is applied, and the next update() reports every change since the last
// completed one.
TEST(BroadPhase, FilterThatThrowsAppliesNothing) {
  for (unsigned threads : {1u, 2u}) {
    SCOPED_TRACE(threads);
    BroadPhase bp({.threads = threads});
    std::vector<Aabb> boxes;
    for (int i = 0; i < 400; ++i) boxes.push_back(shifted(kUnit, 0.5f * static_cast<float>(i)));
    const std::vector<Handle> h = bp.add(boxes);
    const Aabb wall{{-1, -1, -1}, {300, 0, 300}};  // touches every box's bottom face
    const Handle s = bp.add(std::span<const Aabb>(&wall, 1), {.is_static = true})[0];
    const std::vector<Pair> first = bp.update().pairs;  // neighbours 1 and 2 apart (touching), and the wall
    ASSERT_EQ(first.size(), 399u + 398u + 400u);

    // Off the wall, 0.75 apart: only next neighbours overlap.
    std::vector<Pair> now;
    for (std::size_t i = 0; i < boxes.size(); ++i) {
      const float x = 0.75f * static_cast<float>(i);
      boxes[i] = {{x, 5, 0}, {x + 1, 6, 1}};
      if (i > 0) now.push_back({h[i - 1], h[i]});
    }
    bp.move(h, boxes);
    bp.set_pair_filter([](Handle, Handle) -> bool { throw std::runtime_error("filter failed"); });
    EXPECT_THROW(bp.update(), std::runtime_error);
    EXPECT_EQ(bp.last_update().pairs, first) << "the failed frame is not applied";
    EXPECT_EQ(bp.stats().moved, 400u) << "the stats are the last completed frame's (every object added)";

    bp.set_pair_filter({});
    const hbp::BroadPhaseUpdate& u = bp.update();
    EXPECT_EQ(u.pairs, now);
    EXPECT_EQ(u.removed, minus(first, now));
    EXPECT_EQ(u.created, minus(now, first));
    EXPECT_EQ(u.removed.size(), 398u + 400u);
    EXPECT_EQ(bp.stats().moved, 400u);
    EXPECT_EQ(bp.stats().static_changes, 0u);
    (void)s;
  }
}

// stats().moved and static_changes count objects, once each: not rows, not
// moves to the box an object already has. Both move paths (the whole-frame
// batch of every moving object and the general one) and their mixes.
TEST(BroadPhase, StatsCountChangedObjectsOnce) {
  BroadPhase bp({.threads = 2});
  std::vector<Aabb> boxes;
  for (int i = 0; i < 100; ++i) boxes.push_back(shifted(kUnit, 3.0f * static_cast<float>(i)));
  const std::vector<Handle> h = bp.add(boxes);
  const Aabb wall{{0, -5, 0}, {1, -4, 1}};
  const std::vector<Handle> s = bp.add(std::span<const Aabb>(&wall, 1), {.is_static = true});
  bp.update();
  EXPECT_EQ(bp.stats().moved, 100u);
  EXPECT_EQ(bp.stats().static_changes, 1u);
  const auto move_one = [&](Handle x, const Aabb& b) { bp.move(std::span<const Handle>(&x, 1), std::span<const Aabb>(&b, 1)); };

  // The case: one object moved twice, one to its own box.
  move_one(h[1], shifted(boxes[1], 1));
  move_one(h[1], shifted(boxes[1], 2));
  move_one(h[2], boxes[2]);
  move_one(s[0], wall);
  bp.update();
  EXPECT_EQ(bp.stats().moved, 1u);
  EXPECT_EQ(bp.stats().static_changes, 0u);
  boxes[1] = shifted(boxes[1], 2);

  // Whole-frame batches: half the boxes changed; then again in the same
  // frame (the changed half again, and two more); then single moves.
  std::vector<Aabb> next = boxes;
  for (int i = 0; i < 100; i += 2) next[i] = shifted(next[i], 0.5f);
  bp.move(h, next);
  bp.move(h, next);  // nothing new
  next[1] = shifted(next[1], 0.5f);
  next[0] = shifted(next[0], 0.5f);  // already counted
  bp.move(h, next);
  move_one(h[3], shifted(next[3], 1));
  move_one(h[3], next[3]);  // back: it was changed this frame, counted once
  move_one(h[4], shifted(next[4], 1));  // counted by the whole-frame batch already
  bp.update();
  EXPECT_EQ(bp.stats().moved, 50u + 1u + 1u);
  next[4] = shifted(next[4], 1);

  // A whole-frame batch, then a membership change in the same frame.
  std::vector<Aabb> again = next;
  for (int i = 0; i < 10; ++i) again[i] = shifted(again[i], 0.25f);
  bp.move(h, again);
  const Aabb extra = shifted(kUnit, -50);
  const std::vector<Handle> added = bp.add(std::span<const Aabb>(&extra, 1));
  move_one(h[5], shifted(again[5], 1));  // counted already
  move_one(h[50], shifted(again[50], 1));
  move_one(added[0], shifted(extra, 1));  // added this frame: counted once
  bp.remove(std::span<const Handle>(&h[7], 1));
  bp.remove(s);
  bp.update();
  EXPECT_EQ(bp.stats().moved, 10u + 1u + 1u);
  EXPECT_EQ(bp.stats().static_changes, 1u);
}

// ---- conveniences: one-box add, braced rays, caller buffers, visitors -------

namespace {

using hbp::Aabb;
using hbp::BroadPhase;
using hbp::Handle;

// Every object the brute-force scan of `now` finds for a ray, by entry t.
std::vector<Handle> ref_ray_hits(const float o[3], const float d[3], float max_t, const std::vector<Aabb>& now,
                                 const std::vector<Handle>& handles) {
  std::vector<std::pair<float, Handle>> hits;
  for (std::size_t i = 0; i < now.size(); ++i) {
    float t;
    if (ref_ray(o, d, max_t, now[i], t)) hits.emplace_back(t, handles[i]);
  }
  std::sort(hits.begin(), hits.end());
  std::vector<Handle> out;
  for (const auto& h : hits) out.push_back(h.second);
  return out;
}

TEST(BroadPhase, AddOneBoxIsTheBatchAddOfOne) {
  std::mt19937 rng(41);
  BroadPhase one, batch;
  std::vector<Aabb> boxes(200);
  for (Aabb& b : boxes) b = random_box(rng, 20);
  std::vector<Handle> h1;
  for (std::size_t i = 0; i < boxes.size(); ++i)
    h1.push_back(one.add(boxes[i], {.is_static = i % 3 == 0, .layer = static_cast<std::uint8_t>(i % 4)}));
  std::vector<Handle> h2;
  for (std::size_t i = 0; i < boxes.size(); ++i) {
    const auto h = batch.add(std::span<const Aabb>(&boxes[i], 1),
                             {.is_static = i % 3 == 0, .layer = static_cast<std::uint8_t>(i % 4)});
    h2.push_back(h[0]);
  }
  EXPECT_EQ(h1, h2);
  for (std::size_t i = 0; i < boxes.size(); ++i) {
    const Aabb got = one.box(h1[i]);
    EXPECT_EQ(std::memcmp(&boxes[i], &got, sizeof(Aabb)), 0) << i;
    EXPECT_EQ(one.is_static(h1[i]), i % 3 == 0);
    EXPECT_EQ(one.layer(h1[i]), i % 4);
  }
  const auto& u1 = one.update();
  EXPECT_FALSE(u1.pairs.empty());
  EXPECT_EQ(u1.pairs, batch.update().pairs);
  // A malformed box is refused naming it, and adds nothing.
  const float nan = std::numeric_limits<float>::quiet_NaN();
  try {
    one.add(Aabb{{0, nan, 0}, {1, 1, 1}});
    FAIL() << "NaN box accepted";
  } catch (const hbp::InvalidInput& e) {
    EXPECT_NE(std::string(e.what()).find("NaN"), std::string::npos) << e.what();
  }
  EXPECT_EQ(one.size(), boxes.size());
}

TEST(BroadPhase, BufferAndVisitorQueriesMatchBruteForce) {
  std::mt19937 rng(43);
  BroadPhase bp({.threads = 2});
  std::vector<Aabb> now(600);
  for (Aabb& b : now) b = random_box(rng, 25);
  std::vector<Handle> handles = bp.add(std::span<const Aabb>(now).first(400));
  const auto hs = bp.add(std::span<const Aabb>(now).subspan(400), {.is_static = true});
  handles.insert(handles.end(), hs.begin(), hs.end());
  bp.update();

  std::vector<Handle> buffer{7, 7, 7};  // stale contents: cleared by the query
  std::uint64_t box_hits = 0, ray_hits = 0, early_outs = 0;
  std::uniform_real_distribution<float> u(-2, 27);
  for (int q = 0; q < 200; ++q) {
    const Aabb query = random_box(rng, 25);
    std::vector<Handle> want;
    for (std::size_t i = 0; i < now.size(); ++i)
      if (hbp::overlaps(now[i], query)) want.push_back(handles[i]);
    std::sort(want.begin(), want.end());

    ASSERT_EQ(bp.query_box(query, buffer), want.size());
    ASSERT_EQ(buffer, want) << "box " << q;
    std::vector<Handle> visited;
    ASSERT_EQ(bp.query_box(query, [&](Handle h) { visited.push_back(h); return true; }), want.size());
    ASSERT_EQ(visited, want);
    box_hits += want.size();
    if (want.size() >= 2) {  // early out after two: the first two, two calls
      visited.clear();
      const std::size_t calls = bp.query_box(query, [&](Handle h) { visited.push_back(h); return visited.size() < 2; });
      ASSERT_EQ(calls, 2u);
      ASSERT_EQ(visited, std::vector<Handle>(want.begin(), want.begin() + 2));
      ++early_outs;
    }

    const hbp::BroadPhase::Vec3f o{u(rng), u(rng), u(rng)}, d{u(rng) - 12, u(rng) - 12, u(rng) - 12};
    const float max_t = q % 5 == 0 ? std::numeric_limits<float>::infinity() : 2.0f;
    const std::vector<Handle> want_ray = ref_ray_hits(o.data(), d.data(), max_t, now, handles);
    ASSERT_EQ(bp.query_ray(o, d, max_t), want_ray) << "ray " << q;
    ASSERT_EQ(bp.query_ray(o, d, max_t, buffer), want_ray.size());
    ASSERT_EQ(buffer, want_ray);
    // Nearest hit: stop after the first.
    Handle nearest = hbp::kInvalidHandle;
    const std::size_t calls = bp.query_ray(o, d, max_t, [&](Handle h) { nearest = h; return false; });
    ASSERT_EQ(calls, want_ray.empty() ? 0u : 1u);
    ASSERT_EQ(nearest, want_ray.empty() ? hbp::kInvalidHandle : want_ray.front());
    ray_hits += want_ray.size();
  }
  EXPECT_GT(box_hits, 200u);
  EXPECT_GT(ray_hits, 100u);
  EXPECT_GT(early_outs, 20u);
}

TEST(BroadPhase, BracedRaysAndNestedVisitorQueries) {
  BroadPhase bp;
  // Three unit boxes along x at 2, 4 and 6, one off the axis.
  std::vector<Handle> h;
  for (float x : {6.0f, 2.0f, 4.0f}) h.push_back(bp.add(Aabb{{x, 0, 0}, {x + 1, 1, 1}}));
  const Handle off = bp.add(Aabb{{2, 5, 0}, {3, 6, 1}});
  // Braced lists: integer literals and float ones.
  EXPECT_EQ(bp.query_ray({0, 0.5f, 0.5f}, {1, 0, 0}, 10), (std::vector<Handle>{h[1], h[2], h[0]}));
  EXPECT_EQ(bp.query_ray({0, 0.5f, 0.5f}, {1, 0, 0}, 4.5f), (std::vector<Handle>{h[1], h[2]}));
  EXPECT_EQ(bp.query_ray({2.5f, 0, 0.5f}, {0, 1, 0}, 100), (std::vector<Handle>{h[1], off}));
  // A visitor that runs queries of its own: the outer visit still sees every hit.
  std::vector<std::pair<Handle, std::size_t>> seen;
  const std::size_t calls = bp.query_box(Aabb{{0, 0, 0}, {10, 10, 10}}, [&](Handle a) {
    seen.emplace_back(a, bp.query_box(bp.box(a), [](Handle) { return true; }));
    return true;
  });
  EXPECT_EQ(calls, 4u);
  const std::vector<std::pair<Handle, std::size_t>> want{{h[0], 1}, {h[1], 1}, {h[2], 1}, {off, 1}};
  EXPECT_EQ(seen, want);
  // Errors name the argument, as for the other forms.
  std::vector<Handle> buffer;
  EXPECT_THROW(bp.query_ray({0, 0, 0}, {1, 0, 0}, -1.0f, buffer), hbp::InvalidInput);
  EXPECT_THROW(bp.query_box(Aabb{{1, 0, 0}, {0, 1, 1}}, [](Handle) { return true; }), hbp::InvalidInput);
}

}  // namespace
