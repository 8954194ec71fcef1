// SPDX-License-Identifier: MIT
// BroadPhase object filters (category / mask / group, Box2D's b2Filter rule),
// user data and query filters against a brute-force reference written here:
// every frame of long randomized sequences (adds with filters and user data,
// set_filter / set_user_data batches, moves, removes, layer table and pair
// filter changes, static and moving objects), pairs, created and removed
// compared, 1 and 2 threads side by side; filtered queries against a scan.
#include <gtest/gtest.h>

#include <algorithm>
#include <array>
#include <cstdint>
#include <cstring>
#include <map>
#include <optional>
#include <random>
#include <set>
#include <span>
#include <string>
#include <vector>

#include "grid_boxes.hpp"
#include "hbp/broad_phase.hpp"
#include "hbp/error.hpp"
#include "pair_sets.hpp"
#include "pipeline/box_cast.hpp"
#include "pipeline/ray_segment.hpp"

namespace {

using hbp::Aabb;
using hbp::BroadPhase;
using hbp::Filter;
using hbp::Handle;
using hbp::Pair;
using hbp::test::minus;
using hbp::QueryFilter;
using Vec3f = BroadPhase::Vec3f;

TEST(CollisionFilter, Box2DRule) {
  const Filter d;
  EXPECT_EQ(d.category, 1u);
  EXPECT_EQ(d.mask, ~std::uint64_t{0});
  EXPECT_EQ(d.group, 0);
  EXPECT_TRUE(hbp::should_collide(d, d));
  // Same positive group: always, whatever the bits; same negative: never.
  EXPECT_TRUE(hbp::should_collide({.category = 2, .mask = 0, .group = 3}, {.category = 4, .mask = 0, .group = 3}));
  EXPECT_FALSE(hbp::should_collide({.group = -3}, {.group = -3}));
  // Different groups (or 0): both directions of category & mask.
  EXPECT_TRUE(hbp::should_collide({.group = -3}, {.group = -4}));
  EXPECT_FALSE(hbp::should_collide({.category = 2, .mask = 1}, {.category = 1, .mask = 1}));  // 2 not in b's mask
  EXPECT_TRUE(hbp::should_collide({.category = 2, .mask = 1}, {.category = 1, .mask = 2}));
  EXPECT_FALSE(hbp::should_collide({.category = 1ull << 63, .mask = ~0ull}, {.category = 1, .mask = ~(1ull << 63)}));
  EXPECT_TRUE(hbp::is_default(d));
  EXPECT_FALSE(hbp::is_default({.group = 1}));
}

struct Object {
  Aabb box;
  bool is_static;
  std::uint8_t layer;
  Filter filter;
  std::uint64_t user;
};

bool overlap(const Aabb& a, const Aabb& b) {
  for (int k = 0; k < 3; ++k)
    if (a.max[k] < b.min[k] || b.max[k] < a.min[k]) return false;
  return true;
}

struct Reference {
  std::map<Handle, Object> objects;
  std::array<std::uint32_t, 32> collide;
  int pair_rule = 0;  // 0: no pair filter; else (a + b) % pair_rule != 0 kept
  std::vector<Pair> previous;
  Reference() { collide.fill(0xFFFFFFFFu); }

  bool accepts(Handle a, const Object& oa, Handle b, const Object& ob) const {
    if (!((collide[oa.layer] >> ob.layer) & 1u)) return false;
    if (!hbp::should_collide(oa.filter, ob.filter)) return false;
    return pair_rule == 0 || (a + b) % static_cast<Handle>(pair_rule) != 0;
  }
  std::vector<Pair> pairs() const {
    std::vector<Pair> out;
    for (auto i = objects.begin(); i != objects.end(); ++i)
      for (auto j = std::next(i); j != objects.end(); ++j) {
        if (i->second.is_static && j->second.is_static) continue;
        if (!overlap(i->second.box, j->second.box)) continue;
        if (accepts(i->first, i->second, j->first, j->second)) out.push_back(Pair{i->first, j->first});
      }
    return out;
  }
};

// Filters from a few bits and groups, so every branch of the rule occurs;
// the default half the time (the count of filtered objects returns to 0).
Filter random_filter(std::mt19937& rng) {
  if (rng() % 2) return Filter{};
  Filter f;
  f.category = 1ull << (rng() % 3) | (rng() % 8 == 0 ? 1ull << 63 : 0);
  f.mask = rng() % 3 == 0 ? ~0ull : (rng() & 7) | (rng() % 2 ? 1ull << 63 : 0);
  f.group = static_cast<std::int32_t>(rng() % 5) - 2;
  return f;
}

struct Side {
  BroadPhase bp;
  explicit Side(std::uint32_t threads) : bp({.threads = threads}) {}
};

// One frame of random edits applied to every side and the reference.
void random_edits(std::vector<Side*> sides, Reference& ref, std::mt19937& rng, int world, std::size_t target,
                  bool with_statics) {
  std::vector<Handle> live;
  for (const auto& [h, o] : ref.objects) live.push_back(h);
  const auto pick = [&](std::size_t most) {
    std::vector<Handle> out;
    for (const Handle h : live)
      if (out.size() < most && rng() % 4 == 0) out.push_back(h);
    std::shuffle(out.begin(), out.end(), rng);
    return out;
  };
  if (ref.objects.size() < target || rng() % 4 == 0) {
    const bool is_static = with_statics && rng() % 3 == 0;
    std::vector<Aabb> boxes(1 + rng() % 6);
    for (Aabb& b : boxes) b = hbp::test::grid_box(rng, world, 5);
    const hbp::AddOptions o{.is_static = is_static,
                            .layer = static_cast<std::uint8_t>(rng() % 3),
                            .filter = random_filter(rng),
                            .user_data = (std::uint64_t{rng()} << 32) | rng()};
    std::vector<Handle> got;
    for (Side* s : sides) {
      const std::vector<Handle> h = s->bp.add(boxes, o);
      if (!got.empty()) {
        ASSERT_EQ(h, got);
      }
      got = h;
    }
    for (std::size_t i = 0; i < got.size(); ++i) ref.objects[got[i]] = {boxes[i], is_static, o.layer, o.filter, o.user_data};
  }
  switch (rng() % 10) {
    case 0: {  // remove some
      const std::vector<Handle> r = pick(4);
      for (Side* s : sides) s->bp.remove(r);
      for (const Handle h : r) ref.objects.erase(h);
      break;
    }
    case 1:
    case 2: {  // set_filter on a batch
      const std::vector<Handle> r = pick(20);
      const Filter f = random_filter(rng);
      for (Side* s : sides) s->bp.set_filter(r, f);
      for (const Handle h : r) ref.objects[h].filter = f;
      break;
    }
    case 3: {  // set_user_data
      const std::vector<Handle> r = pick(20);
      std::vector<std::uint64_t> v(r.size());
      for (auto& x : v) x = rng();
      for (Side* s : sides) s->bp.set_user_data(r, v);
      for (std::size_t i = 0; i < r.size(); ++i) ref.objects[r[i]].user = v[i];
      break;
    }
    case 4: {  // layer table
      const std::uint32_t a = rng() % 3, b = rng() % 3;
      const bool c = rng() % 2;
      for (Side* s : sides) s->bp.set_collides(a, b, c);
      if (c) {
        ref.collide[a] |= 1u << b;
        ref.collide[b] |= 1u << a;
      } else {
        ref.collide[a] &= ~(1u << b);
        ref.collide[b] &= ~(1u << a);
      }
      break;
    }
    case 5: {  // pair filter on / off
      ref.pair_rule = rng() % 2 ? 0 : 3;
      for (Side* s : sides) {
        if (ref.pair_rule == 0)
          s->bp.set_pair_filter({});
        else
          s->bp.set_pair_filter([](Handle a, Handle b) { return (a + b) % 3 != 0; });
      }
      break;
    }
    case 6: {  // everything back to the defaults: the unfiltered paths again
      std::vector<Handle> all = live;
      all.erase(std::remove_if(all.begin(), all.end(), [&](Handle h) { return !ref.objects.count(h); }), all.end());
      for (Side* s : sides) {
        s->bp.set_filter(all, Filter{});
        s->bp.set_pair_filter({});
        for (std::uint32_t a = 0; a < 3; ++a)
          for (std::uint32_t b = 0; b < 3; ++b) s->bp.set_collides(a, b, true);
      }
      for (const Handle h : all) ref.objects[h].filter = Filter{};
      ref.pair_rule = 0;
      ref.collide.fill(0xFFFFFFFFu);
      break;
    }
    default: break;
  }
  // Moves: nudges, now and then a teleport; static objects too.
  std::vector<Handle> hs;
  std::vector<Aabb> bs;
  for (auto& [h, o] : ref.objects) {
    if (o.is_static ? rng() % 40 != 0 : rng() % 3 == 0) continue;
    Aabb b = o.box;
    if (rng() % 12 == 0) {
      b = hbp::test::grid_box(rng, world, 5);
    } else {
      const int k = static_cast<int>(rng() % 3);
      const float s = 0.5f * (static_cast<float>(rng() % 3) - 1.0f);
      b.min[k] += s;
      b.max[k] += s;
    }
    o.box = b;
    hs.push_back(h);
    bs.push_back(b);
  }
  for (Side* s : sides) s->bp.move(hs, bs);
}

void check_frame(std::vector<Side*> sides, Reference& ref) {
  const std::vector<Pair> want = ref.pairs();
  const std::vector<Pair> created = minus(want, ref.previous), removed = minus(ref.previous, want);
  for (Side* s : sides) {
    const hbp::BroadPhaseUpdate& u = s->bp.update();
    ASSERT_EQ(u.pairs, want);
    ASSERT_EQ(u.created, created);
    ASSERT_EQ(u.removed, removed);
    // User data handed back with the pairs: slot lookups, 0 for objects gone.
    std::vector<std::array<std::uint64_t, 2>> ud(u.created.size());
    s->bp.pair_user_data(u.created, ud);
    for (std::size_t i = 0; i < ud.size(); ++i) {
      ASSERT_EQ(ud[i][0], ref.objects.at(u.created[i].a).user);
      ASSERT_EQ(ud[i][1], ref.objects.at(u.created[i].b).user);
    }
    ud.resize(u.removed.size());
    s->bp.pair_user_data(u.removed, ud);
    for (std::size_t i = 0; i < ud.size(); ++i) {
      const auto a = ref.objects.find(u.removed[i].a), b = ref.objects.find(u.removed[i].b);
      ASSERT_EQ(ud[i][0], a == ref.objects.end() ? 0 : a->second.user);
      ASSERT_EQ(ud[i][1], b == ref.objects.end() ? 0 : b->second.user);
    }
    for (const auto& [h, o] : ref.objects) {
      ASSERT_EQ(s->bp.user_data(h), o.user);
      ASSERT_TRUE(s->bp.filter(h) == o.filter);
    }
  }
  ref.previous = want;
}

QueryFilter random_query_filter(std::mt19937& rng) {
  QueryFilter q;
  if (rng() % 3 == 0) return q;
  q.layers_mask = rng() % 2 ? 0xFFFFFFFFu : static_cast<std::uint32_t>(rng() % 8);
  q.category_mask = rng() % 2 ? ~0ull : (rng() & 7) | (rng() % 4 == 0 ? 1ull << 63 : 0);
  return q;
}

bool passes(const QueryFilter& q, const Object& o) {
  return ((q.layers_mask >> o.layer) & 1u) && (o.filter.category & q.category_mask) != 0;
}

void check_filtered_queries(const BroadPhase& bp, const Reference& ref, std::mt19937& rng, int world) {
  for (int n = 0; n < 3; ++n) {
    const QueryFilter q = random_query_filter(rng);
    const Aabb box = hbp::test::grid_box(rng, world, 5);
    std::vector<Handle> want;
    for (const auto& [h, o] : ref.objects)
      if (passes(q, o) && overlap(o.box, box)) want.push_back(h);
    ASSERT_EQ(bp.query_box(box, q), want);
    std::vector<Handle> out;
    ASSERT_EQ(bp.query_box(box, out, q), want.size());
    ASSERT_EQ(out, want);
    std::vector<Handle> first;
    ASSERT_EQ(bp.query_box(box, [&](Handle h) { first.push_back(h); return false; }, q), std::min<std::size_t>(1, want.size()));
    ASSERT_TRUE(std::equal(first.begin(), first.end(), want.begin()));

    const Vec3f o = {0.5f * float(rng() % (2 * world)), 0.5f * float(rng() % (2 * world)), -1.0f};
    const Vec3f d = {0.5f * (float(rng() % 5) - 2.0f), 0.5f * (float(rng() % 5) - 2.0f), 1.0f};
    const float max_t = float(world);
    const hbp::detail::RaySegment ray(o.data(), d.data(), max_t);
    const hbp::detail::BoxCast cast(box, d.data());
    std::vector<std::pair<float, Handle>> rh, ch;
    for (const auto& [h, ob] : ref.objects) {
      if (!passes(q, ob)) continue;
      float t;
      if (ray.hits(ob.box.min, ob.box.max, t)) rh.emplace_back(t, h);
      if (cast.hits(ob.box.min, ob.box.max, t)) ch.emplace_back(t, h);
    }
    std::sort(rh.begin(), rh.end());
    std::sort(ch.begin(), ch.end());
    std::vector<Handle> rwant, cwant;
    for (const auto& x : rh) rwant.push_back(x.second);
    for (const auto& x : ch) cwant.push_back(x.second);
    ASSERT_EQ(bp.query_ray(o, d, max_t, q), rwant);
    ASSERT_EQ(bp.query_ray(o, d, max_t, out, q), rwant.size());
    ASSERT_EQ(out, rwant);
    const std::optional<hbp::RayHit> c = bp.raycast_closest(o, d, max_t, q);
    ASSERT_EQ(c.has_value(), !rh.empty());
    if (c) {
      ASSERT_EQ(c->handle, rh[0].second);
      ASSERT_EQ(c->t, rh[0].first);
    }
    std::vector<Handle> visited;
    bp.query_ray(o, d, max_t, [&](Handle h) { visited.push_back(h); return visited.size() < 2; }, q);
    ASSERT_EQ(visited, std::vector<Handle>(rwant.begin(), rwant.begin() + std::min<std::size_t>(2, rwant.size())));
    ASSERT_EQ(bp.query_box_cast(box, d, q), cwant);
    ASSERT_EQ(bp.query_box_cast(box, d, out, q), cwant.size());
    visited.clear();
    bp.query_box_cast(box, d, [&](Handle h) { visited.push_back(h); return true; }, q);
    ASSERT_EQ(visited, cwant);
    // The default filter is the unfiltered query.
    ASSERT_EQ(bp.query_box(box, QueryFilter{}), bp.query_box(box));
  }
}

void run(std::uint32_t seed, int frames, int world, std::size_t target, bool with_statics) {
  std::mt19937 rng(seed);
  Side one(1), two(2);
  Reference ref;
  for (int f = 0; f < frames; ++f) {
    random_edits({&one, &two}, ref, rng, world, target, with_statics);
    if (::testing::Test::HasFatalFailure()) return;
    check_frame({&one, &two}, ref);
    if (::testing::Test::HasFatalFailure()) return;
    if (f % 3 == 0) check_filtered_queries(one.bp, ref, rng, world);
    if (::testing::Test::HasFatalFailure()) return;
  }
}

}  // namespace

TEST(BroadPhaseFilters, RandomSequencesWithStaticsMatchBruteForce) {
  for (std::uint32_t seed : {1u, 2u}) {
    SCOPED_TRACE(seed);
    run(seed, 1500, 10, 150, true);
    if (HasFatalFailure()) return;
  }
}

TEST(BroadPhaseFilters, AllMovingSequencesMatchBruteForce) {
  // No statics: the all-moving frame whenever no filter is in force, the
  // general path while one is.
  run(3, 2000, 10, 150, false);
}

TEST(BroadPhaseFilters, ErrorsChangeNothing) {
  BroadPhase bp;
  const std::vector<Handle> h = bp.add(std::vector<Aabb>(3, Aabb{{0, 0, 0}, {1, 1, 1}}), {.user_data = 7});
  EXPECT_EQ(bp.user_data(h[2]), 7u);
  EXPECT_THROW(bp.set_user_data(h, std::vector<std::uint64_t>{1, 2}), hbp::InvalidInput);
  EXPECT_THROW(bp.set_filter(std::vector<Handle>{h[0], h[0]}, Filter{.group = -1}), hbp::InvalidInput);
  EXPECT_TRUE(hbp::is_default(bp.filter(h[0])));
  EXPECT_THROW(bp.set_user_data(std::vector<Handle>{h[1], 999}, std::vector<std::uint64_t>{1, 2}), hbp::InvalidInput);
  EXPECT_EQ(bp.user_data(h[1]), 7u);
  std::vector<std::array<std::uint64_t, 2>> out(1);
  EXPECT_THROW(bp.pair_user_data(std::vector<Pair>(2, Pair{h[0], h[1]}), out), hbp::InvalidInput);
  bp.remove(std::vector<Handle>{h[0]});
  EXPECT_THROW(bp.user_data(h[0]), hbp::InvalidInput);
  EXPECT_THROW(bp.filter(h[0]), hbp::InvalidInput);
  std::vector<std::uint64_t> ud(2);
  bp.user_data(std::vector<Handle>{h[0], h[1]}, ud);
  EXPECT_EQ(ud, (std::vector<std::uint64_t>{0, 7}));
  // Same negative group: the pair is never stored.
  bp.set_filter(std::vector<Handle>{h[1], h[2]}, Filter{.group = -5});
  EXPECT_TRUE(bp.update().pairs.empty());
  bp.set_filter(std::vector<Handle>{h[1]}, Filter{});
  EXPECT_EQ(bp.update().pairs.size(), 1u);
}
