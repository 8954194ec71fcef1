// SPDX-License-Identifier: MIT
// BroadPhase margins and swept moves against a brute-force reference written
// here: the reference keeps each object's given boxes and derives the stored
// box by the documented rule (grown by the margin; move_swept: the union of
// the previous box and the new one, the previous being the last swept box
// given, else the stored box). Every frame of long randomized sequences
// (adds with margins, set_margin, plain, whole-batch and swept moves,
// removes, static and moving objects, 1 and 2 threads side by side):
// pairs, created, removed, box(h) and queries compared.
#include <gtest/gtest.h>

#include <algorithm>
#include <cstring>
#include <limits>
#include <map>
#include <random>
#include <span>
#include <string>
#include <vector>

#include "grid_boxes.hpp"
#include "hbp/broad_phase.hpp"
#include "hbp/error.hpp"
#include "pair_sets.hpp"

namespace {

using hbp::Aabb;
using hbp::BroadPhase;
using hbp::Handle;
using hbp::Pair;
using hbp::test::minus;

struct Object {
  Aabb stored;
  Aabb end;  // the last swept box given (grown), while `swept`
  bool swept = false;
  bool is_static = false;
  float margin = 0;
};

Aabb grown(const Aabb& b, float m) {
  Aabb g = b;
  for (int k = 0; k < 3; ++k) g.min[k] -= m, g.max[k] += m;
  return g;
}
Aabb united(const Aabb& a, const Aabb& b) {
  Aabb u;
  for (int k = 0; k < 3; ++k) u.min[k] = std::min(a.min[k], b.min[k]), u.max[k] = std::max(a.max[k], b.max[k]);
  return u;
}
bool overlap(const Aabb& a, const Aabb& b) {
  for (int k = 0; k < 3; ++k)
    if (a.max[k] < b.min[k] || b.max[k] < a.min[k]) return false;
  return true;
}
bool same(const Aabb& a, const Aabb& b) { return std::memcmp(&a, &b, sizeof(Aabb)) == 0; }

float random_margin(std::mt19937& rng) {
  static const float m[] = {0.0f, 0.0f, 0.25f, 0.5f, 1.5f};
  return m[rng() % 5];
}

struct Reference {
  std::map<Handle, Object> objects;
  std::vector<Pair> previous;
  std::vector<Pair> pairs() const {
    std::vector<Pair> out;
    for (auto i = objects.begin(); i != objects.end(); ++i)
      for (auto j = std::next(i); j != objects.end(); ++j)
        if (!(i->second.is_static && j->second.is_static) && overlap(i->second.stored, j->second.stored))
          out.push_back(Pair{i->first, j->first});
    return out;
  }
};

void step(std::vector<BroadPhase*> bps, Reference& ref, std::mt19937& rng, int world, std::size_t target,
          bool with_statics) {
  std::vector<Handle> live;
  for (const auto& [h, o] : ref.objects) live.push_back(h);
  if (ref.objects.size() < target || rng() % 5 == 0) {
    const bool is_static = with_statics && rng() % 4 == 0;
    const float m = random_margin(rng);
    std::vector<Aabb> boxes(1 + rng() % 5);
    for (Aabb& b : boxes) b = hbp::test::grid_box(rng, world, 4);
    std::vector<Handle> got;
    for (BroadPhase* bp : bps) got = bp->add(boxes, {.is_static = is_static, .margin = m});
    for (std::size_t i = 0; i < got.size(); ++i) {
      Object o;
      o.stored = grown(boxes[i], m);
      o.is_static = is_static;
      o.margin = m;
      ref.objects[got[i]] = o;
    }
  }
  const auto pick = [&](unsigned one_in) {
    std::vector<Handle> out;
    for (const Handle h : live)
      if (ref.objects.count(h) && rng() % one_in == 0) out.push_back(h);
    return out;
  };
  switch (rng() % 8) {
    case 0: {
      std::vector<Handle> r = pick(25);
      for (BroadPhase* bp : bps) bp->remove(r);
      for (const Handle h : r) ref.objects.erase(h);
      break;
    }
    case 1: {
      const float m = random_margin(rng);
      std::vector<Handle> r = pick(6);
      for (BroadPhase* bp : bps) bp->set_margin(r, m);
      for (const Handle h : r) ref.objects[h].margin = m;
      break;
    }
    case 2: {  // every margin back to 0: the whole-batch move path again
      std::vector<Handle> r = pick(1);
      for (BroadPhase* bp : bps) bp->set_margin(r, 0);
      for (const Handle h : r) ref.objects[h].margin = 0;
      break;
    }
    default: break;
  }
  // Moves: every moving object in handle order now and then (the whole
  // batch), else a subset in random order; swept or plain.
  const bool swept = rng() % 2 == 0;
  const bool whole = rng() % 4 == 0;
  std::vector<Handle> hs;
  std::vector<Aabb> given;
  for (auto& [h, o] : ref.objects) {
    if (o.is_static ? rng() % 30 != 0 : !whole && rng() % 3 != 0) continue;
    Aabb b = hbp::test::grid_box(rng, world, 4);  // a teleport now and then
    if (rng() % 10 != 0) {          // else a step from the last given position
      const Aabb base = o.swept ? o.end : o.stored;
      for (int k = 0; k < 3; ++k) {
        const float c = 0.5f * (base.min[k] + base.max[k]) + 0.5f * (static_cast<float>(rng() % 5) - 2.0f);
        const float half = 0.25f * static_cast<float>(rng() % 4);
        b.min[k] = c - half;
        b.max[k] = c + half;
      }
    }
    hs.push_back(h);
    given.push_back(b);
  }
  if (!whole) {  // any order
    std::vector<std::size_t> order(hs.size());
    for (std::size_t i = 0; i < order.size(); ++i) order[i] = i;
    std::shuffle(order.begin(), order.end(), rng);
    std::vector<Handle> h2;
    std::vector<Aabb> g2;
    for (const std::size_t i : order) h2.push_back(hs[i]), g2.push_back(given[i]);
    hs.swap(h2);
    given.swap(g2);
  }
  for (BroadPhase* bp : bps) {
    if (swept)
      bp->move_swept(hs, given);
    else
      bp->move(hs, given);
  }
  for (std::size_t i = 0; i < hs.size(); ++i) {
    Object& o = ref.objects[hs[i]];
    const Aabb nb = grown(given[i], o.margin);
    if (swept) {
      const Aabb previous = o.swept ? o.end : o.stored;
      o.end = nb;
      o.swept = true;
      o.stored = united(previous, nb);
    } else {
      o.swept = false;
      o.stored = nb;
    }
  }
}

void check(std::vector<BroadPhase*> bps, Reference& ref, std::mt19937& rng, int world) {
  const std::vector<Pair> want = ref.pairs();
  const std::vector<Pair> created = minus(want, ref.previous), removed = minus(ref.previous, want);
  for (BroadPhase* bp : bps) {
    const hbp::BroadPhaseUpdate& u = bp->update();
    ASSERT_EQ(u.pairs, want);
    ASSERT_EQ(u.created, created);
    ASSERT_EQ(u.removed, removed);
    for (const auto& [h, o] : ref.objects) {
      ASSERT_TRUE(same(bp->box(h), o.stored)) << "handle " << h;
      ASSERT_EQ(bp->margin(h), o.margin);
    }
    const Aabb q = hbp::test::grid_box(rng, world, 4);
    std::vector<Handle> hits;
    for (const auto& [h, o] : ref.objects)
      if (overlap(o.stored, q)) hits.push_back(h);
    ASSERT_EQ(bp->query_box(q), hits);
  }
  ref.previous = want;
}

void run(std::uint32_t seed, int frames, bool with_statics) {
  std::mt19937 rng(seed);
  BroadPhase one({.threads = 1}), two({.threads = 2});
  Reference ref;
  for (int f = 0; f < frames; ++f) {
    step({&one, &two}, ref, rng, 10, 150, with_statics);
    check({&one, &two}, ref, rng, 10);
    if (::testing::Test::HasFatalFailure()) return;
  }
}

}  // namespace

TEST(BroadPhaseFastMovers, MarginsAndSweptMovesWithStaticsMatchBruteForce) {
  for (std::uint32_t seed : {1u, 2u}) {
    SCOPED_TRACE(seed);
    run(seed, 1500, true);
    if (HasFatalFailure()) return;
  }
}

TEST(BroadPhaseFastMovers, AllMovingMarginsAndSweptMovesMatchBruteForce) { run(3, 2000, false); }

TEST(BroadPhaseFastMovers, ErrorsChangeNothing) {
  BroadPhase bp;
  const std::vector<Handle> h = bp.add(std::vector<Aabb>(2, Aabb{{0, 0, 0}, {1, 1, 1}}), {.margin = 0.5f});
  EXPECT_TRUE(same(bp.box(h[0]), Aabb{{-0.5f, -0.5f, -0.5f}, {1.5f, 1.5f, 1.5f}}));
  EXPECT_THROW(bp.add(Aabb{{0, 0, 0}, {1, 1, 1}}, {.margin = -1}), hbp::InvalidInput);
  EXPECT_THROW(bp.add(Aabb{{0, 0, 0}, {1, 1, 1}}, {.margin = std::numeric_limits<float>::infinity()}), hbp::InvalidInput);
  EXPECT_THROW(bp.set_margin(h, std::numeric_limits<float>::quiet_NaN()), hbp::InvalidInput);
  const float big = std::numeric_limits<float>::max();
  bp.set_margin(std::vector<Handle>{h[1]}, 1e38f);  // applies to boxes given from now on
  EXPECT_TRUE(same(bp.box(h[1]), Aabb{{-0.5f, -0.5f, -0.5f}, {1.5f, 1.5f, 1.5f}}));
  try {
    bp.move(std::vector<Handle>{h[0], h[1]}, std::vector<Aabb>{Aabb{{0, 0, 0}, {1, 1, 1}}, Aabb{{0, 0, 0}, {big, 1, 1}}});
    ADD_FAILURE() << "an infinite grown box was accepted";
  } catch (const hbp::InvalidInput& e) {
    EXPECT_NE(std::string(e.what()).find("row 1"), std::string::npos) << e.what();
  }
  EXPECT_TRUE(same(bp.box(h[0]), Aabb{{-0.5f, -0.5f, -0.5f}, {1.5f, 1.5f, 1.5f}}));
  EXPECT_EQ(bp.margin(h[1]), 1e38f);
  // Swept: the union with the previous box; a second sweep starts from the first one's end.
  bp.move_swept(std::vector<Handle>{h[0]}, std::vector<Aabb>{Aabb{{4, 0, 0}, {5, 1, 1}}});
  EXPECT_TRUE(same(bp.box(h[0]), Aabb{{-0.5f, -0.5f, -0.5f}, {5.5f, 1.5f, 1.5f}}));
  bp.move_swept(std::vector<Handle>{h[0]}, std::vector<Aabb>{Aabb{{8, 0, 0}, {9, 1, 1}}});
  EXPECT_TRUE(same(bp.box(h[0]), Aabb{{3.5f, -0.5f, -0.5f}, {9.5f, 1.5f, 1.5f}}));
  bp.move(std::vector<Handle>{h[0]}, std::vector<Aabb>{Aabb{{8, 0, 0}, {9, 1, 1}}});
  EXPECT_TRUE(same(bp.box(h[0]), Aabb{{7.5f, -0.5f, -0.5f}, {9.5f, 1.5f, 1.5f}}));
}
