// SPDX-License-Identifier: MIT
// BroadPhase in large worlds: the double-precision path (float32 filter,
// exact double confirmation) against a double brute force at coordinates
// 1e6 .. 1e9, touching faces that float rounding would merge included, and
// shift_origin on float and double worlds.
#include <gtest/gtest.h>

#include <algorithm>
#include <array>
#include <cmath>
#include <limits>
#include <random>
#include <span>
#include <string>
#include <vector>

#include "hbp/broad_phase.hpp"
#include "hbp/error.hpp"
#include "pair_sets.hpp"
#include "sanitizers.hpp"

namespace {

using hbp::Aabb;
using hbp::AabbD;
using hbp::BroadPhase;
using hbp::Handle;
using hbp::Pair;
using hbp::test::minus;

struct Object {
  Handle h;
  bool is_static;
  std::uint8_t layer;
};

template <class Box>
std::vector<Pair> brute_pairs(const std::vector<Object>& objs, const std::vector<Box>& boxes,
                              const BroadPhase& bp) {
  std::vector<Pair> out;
  for (std::size_t i = 0; i < objs.size(); ++i)
    for (std::size_t j = i + 1; j < objs.size(); ++j) {
      if (objs[i].is_static && objs[j].is_static) continue;
      if (!bp.collides(objs[i].layer, objs[j].layer)) continue;
      if (!hbp::overlaps(boxes[i], boxes[j])) continue;
      out.push_back(Pair{std::min(objs[i].h, objs[j].h), std::max(objs[i].h, objs[j].h)});
    }
  std::sort(out.begin(), out.end());
  return out;
}

// A box of sides 0.01 .. 10 at `centre` + a random offset within `spread`.
AabbD random_box(std::mt19937_64& rng, const std::array<double, 3>& centre, double spread) {
  std::uniform_real_distribution<double> pos(-spread, spread), side(0.01, 10.0);
  std::uniform_int_distribution<int> tiny(0, 3);
  AabbD b;
  for (int k = 0; k < 3; ++k) {
    const double s = tiny(rng) == 0 ? std::uniform_real_distribution<double>(0.01, 0.1)(rng) : side(rng);
    b.min[k] = centre[k] + pos(rng);
    b.max[k] = b.min[k] + s;
  }
  return b;
}

// Moves b so that its min face on axis k touches other's max face exactly
// (b.min[k] == other.max[k]), or leaves a gap of `gap` (below a float step
// at large coordinates: the outward float boxes overlap, the double ones
// do not).
void place_against(AabbD& b, const AabbD& other, int k, double gap) {
  const double side = b.max[k] - b.min[k];
  b.min[k] = other.max[k] + gap;
  b.max[k] = b.min[k] + side;
  for (int j = 0; j < 3; ++j) {
    if (j == k) continue;
    const double sj = b.max[j] - b.min[j];
    b.min[j] = other.min[j];
    b.max[j] = b.min[j] + sj;
  }
}

AabbD as_double(const Aabb& b) {
  AabbD d;
  for (int k = 0; k < 3; ++k) {
    d.min[k] = b.min[k];
    d.max[k] = b.max[k];
  }
  return d;
}

// Long randomized run in double-precision mode at `scale`: every frame's
// pairs, created and removed equal the brute force on the double boxes.
void run_double_world(double scale, unsigned threads, int steps, std::uint64_t seed) {
  SCOPED_TRACE("scale " + std::to_string(scale) + " threads " + std::to_string(threads));
  std::mt19937_64 rng(seed);
  BroadPhase bp({.threads = threads, .double_precision = true});
  const std::array<double, 3> centre{scale, -scale, scale * 0.5};
  constexpr double kSpread = 25;
  std::vector<Object> objs;
  std::vector<AabbD> boxes;
  const auto add = [&](std::size_t n, bool is_static, std::uint8_t layer) {
    std::vector<AabbD> b;
    for (std::size_t i = 0; i < n; ++i) b.push_back(random_box(rng, centre, kSpread));
    const std::vector<Handle> h = bp.add(b, {.is_static = is_static, .layer = layer});
    for (std::size_t i = 0; i < n; ++i) {
      objs.push_back({h[i], is_static, layer});
      boxes.push_back(b[i]);
    }
  };
  add(40, true, 0);
  add(160, false, 0);
  add(20, false, 1);
  bp.set_collides(1, 1, false);
  std::vector<Pair> previous;
  std::uniform_real_distribution<double> jitter(-0.5, 0.5), unit(0, 1);
  std::uniform_int_distribution<std::size_t> pick(0, objs.size() - 1);
  std::uniform_int_distribution<int> axis(0, 2);
  std::size_t touching = 0, merged_by_float = 0;
  for (int step = 0; step < steps; ++step) {
    // A few objects move (statics too, now and then): jitter, or placed
    // exactly against another box, or a sub-float gap away from it.
    std::vector<Handle> mh;
    std::vector<AabbD> mb;
    std::vector<char> taken(objs.size(), 0);
    for (int m = 0; m < 12; ++m) {
      const std::size_t i = pick(rng);
      if (taken[i] || (objs[i].is_static && unit(rng) < 0.8)) continue;
      taken[i] = 1;
      AabbD b = boxes[i];
      const double r = unit(rng);
      if (r < 0.3) {
        const int k = axis(rng);
        const double gap = unit(rng) < 0.5 ? 0.0 : std::ldexp(1.0, -20) * std::max(1.0, scale / 1e6);
        place_against(b, boxes[pick(rng)], k, gap);
        (gap == 0 ? touching : merged_by_float) += 1;
      } else if (r < 0.35) {
        b = random_box(rng, centre, kSpread);
      } else {
        for (int k = 0; k < 3; ++k) {
          const double d = jitter(rng);
          b.min[k] += d;
          b.max[k] += d;
        }
      }
      mh.push_back(objs[i].h);
      mb.push_back(b);
      boxes[i] = b;
    }
    bp.move(mh, mb);
    if (step % 500 == 250) {  // membership changes too
      bp.remove(std::span<const Handle>(&objs.back().h, 1));
      objs.pop_back();
      boxes.pop_back();
      const AabbD b = random_box(rng, centre, kSpread);
      objs.push_back({bp.add(b), false, 0});
      boxes.push_back(b);
    }
    const hbp::BroadPhaseUpdate& u = bp.update();
    const std::vector<Pair> want = brute_pairs(objs, boxes, bp);
    ASSERT_EQ(u.pairs, want) << "step " << step;
    ASSERT_EQ(u.created, minus(want, previous)) << "step " << step;
    ASSERT_EQ(u.removed, minus(previous, want)) << "step " << step;
    previous = want;
  }
  EXPECT_GT(touching, 100u);
  EXPECT_GT(merged_by_float, 100u);
  EXPECT_GT(previous.size(), 10u);
  for (std::size_t i = 0; i < objs.size(); ++i) {
    const AabbD b = bp.box_d(objs[i].h);
    ASSERT_EQ(b.min, boxes[i].min);
    ASSERT_EQ(b.max, boxes[i].max);
  }
}

TEST(BroadPhaseLargeWorld, DoubleMatchesBruteForceAtLargeCoordinates) {
  constexpr int kSteps = hbp::test::kThreadSanitizer ? 400 : 2000;  // sanitizers.hpp
  std::uint64_t seed = 1;
  for (double scale : {1e6, 1e7, 1e8, 1e9})
    for (unsigned threads : {1u, 2u}) run_double_world(scale, threads, kSteps, seed++);
}

// Doubles that are all floats (the float test is the double test, and the
// confirmation has nothing to do), then some of them nudged off the float
// grid and back; with and without a filter, handles past dense indices.
TEST(BroadPhaseLargeWorld, FloatExactDoublesAndMixedWorlds) {
  for (unsigned threads : {1u, 2u}) {
    std::mt19937_64 rng(40 + threads);
    BroadPhase bp({.threads = threads, .double_precision = true});
    std::uniform_real_distribution<float> pos(0, 60), side(0.1f, 6);
    std::vector<Object> objs;
    std::vector<AabbD> boxes;
    const auto float_box = [&] {
      AabbD b;
      for (int k = 0; k < 3; ++k) {
        const float lo = pos(rng);
        b.min[k] = lo;
        b.max[k] = lo + side(rng);  // a float sum: exact as a double
      }
      return b;
    };
    for (int i = 0; i < 400; ++i) {
      const AabbD b = float_box();
      objs.push_back({bp.add(b), false, 0});
      boxes.push_back(b);
    }
    std::vector<Pair> previous;
    for (int step = 0; step < 600; ++step) {
      if (step == 200) {  // handles no longer dense indices
        bp.remove(std::span<const Handle>(&objs[3].h, 1));
        objs.erase(objs.begin() + 3);
        boxes.erase(boxes.begin() + 3);
      }
      std::uniform_int_distribution<std::size_t> pick(0, objs.size() - 1);  // after the removal too
      if (step == 400)
        bp.set_pair_filter([](Handle a, Handle b) { return (a + b) % 5 != 0; });
      std::vector<Handle> mh;
      std::vector<AabbD> mb;
      std::vector<char> taken(objs.size(), 0);
      for (int m = 0; m < 20; ++m) {
        const std::size_t i = pick(rng);
        if (taken[i]) continue;
        taken[i] = 1;
        AabbD b = float_box();
        if (step % 100 >= 50 && m % 4 == 0) {  // off the float grid (for a while)
          b.min[0] += 1e-9;
          b.max[0] += 1e-9;
        }
        mh.push_back(objs[i].h);
        mb.push_back(b);
        boxes[i] = b;
      }
      bp.move(mh, mb);
      const hbp::BroadPhaseUpdate& u = bp.update();
      std::vector<Pair> want = brute_pairs(objs, boxes, bp);
      if (step >= 400)
        std::erase_if(want, [](const Pair& p) { return (p.a + p.b) % 5 == 0; });
      ASSERT_EQ(u.pairs, want) << "step " << step;
      ASSERT_EQ(u.created, minus(want, previous)) << "step " << step;
      ASSERT_EQ(u.removed, minus(previous, want)) << "step " << step;
      previous = want;
    }
  }
}

// Boxes a float32 world cannot tell apart: a 1e-6 gap at 1e7 (a float step
// there is 1) merges the float boxes; the double path keeps them apart, and
// keeps exactly touching faces together.
TEST(BroadPhaseLargeWorld, SubFloatGapsAndTouchingFaces) {
  for (double scale : {1e6, 1e7, 1e8, 1e9}) {
    BroadPhase bp({.threads = 2, .double_precision = true});
    const AabbD a{{scale + 0.25, 0, 0}, {scale + 1.3, 1, 1}};
    const AabbD apart{{scale + 1.3 + 1e-6, 0, 0}, {scale + 2.7, 1, 1}};
    const AabbD touching{{0, scale + 0.1, 0}, {1, scale + 0.2, 1}};
    const AabbD touches_it{{1, scale + 0.2, 1}, {2, scale + 0.3, 2}};  // touches on three axes (an edge corner)
    const Handle ha = bp.add(a), hb = bp.add(apart), hc = bp.add(touching), hd = bp.add(touches_it);
    const Aabb fa{{static_cast<float>(a.min[0]), 0, 0}, {static_cast<float>(a.max[0]), 1, 1}};
    const Aabb fb{{static_cast<float>(apart.min[0]), 0, 0}, {static_cast<float>(apart.max[0]), 1, 1}};
    ASSERT_TRUE(hbp::overlaps(fa, fb)) << "the float boxes must merge for this test to mean anything";
    const auto& u = bp.update();
    EXPECT_EQ(u.pairs, (std::vector<Pair>{{hc, hd}})) << scale;
    (void)ha;
    (void)hb;
    // The same world with a filter: it is asked about confirmed pairs only.
    std::vector<Pair> asked;
    bp.set_pair_filter([&](Handle x, Handle y) {
      asked.push_back({x, y});
      return true;
    });
    bp.move(std::span<const Handle>(&hb, 1), std::span<const AabbD>(&apart, 1));
    EXPECT_EQ(bp.update().pairs, (std::vector<Pair>{{hc, hd}}));
    EXPECT_EQ(asked, (std::vector<Pair>{{hc, hd}}));
  }
}

TEST(BroadPhaseLargeWorld, DoubleQueriesAreExact) {
  std::mt19937_64 rng(7);
  for (double scale : {1e7, 1e9}) {
    BroadPhase bp({.threads = 2, .double_precision = true});
    const std::array<double, 3> centre{scale, scale, -scale};
    std::vector<AabbD> boxes;
    for (int i = 0; i < 300; ++i) boxes.push_back(random_box(rng, centre, 20));
    std::vector<Handle> h = bp.add(std::span<const AabbD>(boxes.data(), 150));
    const std::vector<Handle> hs =
        bp.add(std::span<const AabbD>(boxes.data() + 150, 150), {.is_static = true});
    h.insert(h.end(), hs.begin(), hs.end());
    for (int q = 0; q < 200; ++q) {
      AabbD box = random_box(rng, centre, 20);
      if (q % 3 == 0) place_against(box, boxes[static_cast<std::size_t>(q)], q % 3, q % 2 ? 0.0 : 1e-6);
      std::vector<Handle> want;
      for (std::size_t i = 0; i < boxes.size(); ++i)
        if (hbp::overlaps(boxes[i], box)) want.push_back(h[i]);
      std::sort(want.begin(), want.end());
      ASSERT_EQ(bp.query_box(box), want);
      std::vector<Handle> out;
      ASSERT_EQ(bp.query_box(box, out), want.size());
      ASSERT_EQ(out, want);
    }
    // Rays test the outward float boxes: every box the segment touches is
    // among the hits (a ray along x through the middle of box i, from well
    // before it).
    int rays = 0;
    for (std::size_t i = 0; i < boxes.size(); i += 7) {
      const AabbD& b = boxes[i];
      const std::array<float, 3> o{static_cast<float>(b.min[0] - 100), static_cast<float>(std::ceil(b.min[1])),
                                   static_cast<float>(std::ceil(b.min[2]))};
      if (o[1] < b.min[1] || o[1] > b.max[1] || o[2] < b.min[2] || o[2] > b.max[2]) continue;  // rounded out of it
      const std::vector<Handle> hits = bp.query_ray(o, {1, 0, 0}, 1000);
      ASSERT_NE(std::find(hits.begin(), hits.end(), h[i]), hits.end()) << i;
      ++rays;
    }
    if (scale < 1e8) {
      EXPECT_GT(rays, 5);  // integers are floats there
    }
    // A float query box on a double BroadPhase is the double box it denotes.
    Aabb fq;
    for (int k = 0; k < 3; ++k) {
      const double c = centre[static_cast<std::size_t>(k)];
      fq.min[k] = static_cast<float>(c);
      fq.max[k] = std::nextafter(std::nextafter(fq.min[k], 3e38f), 3e38f);  // two float steps up
    }
    const AabbD dq = as_double(fq);
    std::vector<Handle> want;
    for (std::size_t i = 0; i < boxes.size(); ++i)
      if (hbp::overlaps(boxes[i], dq)) want.push_back(h[i]);
    std::sort(want.begin(), want.end());
    EXPECT_EQ(bp.query_box(dq), want);
    EXPECT_EQ(bp.query_box(fq), want);
  }
}

// Float world: random boxes near `base`; after shift_origin the pairs are
// the brute force of the boxes shifted with float subtraction, events are
// the difference, and later frames (moves in the new frame) stay exact.
void run_float_shift(float base, float spread, const std::array<float, 3>& offset, unsigned threads,
                     bool expect_no_events, std::uint64_t seed) {
  SCOPED_TRACE("base " + std::to_string(base) + " threads " + std::to_string(threads));
  std::mt19937_64 rng(seed);
  std::uniform_real_distribution<float> pos(-spread, spread), side(0.01f, 10.0f), jitter(-0.5f, 0.5f);
  const auto make = [&](float cx) {
    Aabb b;
    for (int k = 0; k < 3; ++k) {
      b.min[k] = (k == 0 ? cx : 0.0f) + pos(rng);
      b.max[k] = b.min[k] + side(rng);
    }
    return b;
  };
  BroadPhase bp({.threads = threads});
  std::vector<Object> objs;
  std::vector<Aabb> boxes;
  for (int i = 0; i < 200; ++i) {
    const bool is_static = i < 60;
    const Aabb b = make(base);
    objs.push_back({bp.add(b, {.is_static = is_static}), is_static, 0});
    boxes.push_back(b);
  }
  std::vector<Pair> previous = brute_pairs(objs, boxes, bp);
  ASSERT_EQ(bp.update().pairs, previous);
  bp.query_box(boxes[0]);  // builds the query trees, which the shift must refresh
  bp.shift_origin(offset);
  for (Aabb& b : boxes)
    for (int k = 0; k < 3; ++k) {
      b.min[k] = b.min[k] - offset[k];
      b.max[k] = b.max[k] - offset[k];
    }
  for (std::size_t i = 0; i < objs.size(); ++i) {
    const Aabb b = bp.box(objs[i].h);
    for (int k = 0; k < 3; ++k) {
      ASSERT_EQ(b.min[k], boxes[i].min[k]);
      ASSERT_EQ(b.max[k], boxes[i].max[k]);
    }
  }
  for (int q = 0; q < 20; ++q) {  // the queries see the shifted boxes
    std::vector<Handle> want;
    for (std::size_t i = 0; i < boxes.size(); ++i)
      if (hbp::overlaps(boxes[i], boxes[static_cast<std::size_t>(q)])) want.push_back(objs[i].h);
    std::sort(want.begin(), want.end());
    ASSERT_EQ(bp.query_box(boxes[static_cast<std::size_t>(q)]), want);
  }
  std::uniform_int_distribution<std::size_t> pick(0, objs.size() - 1);
  for (int step = 0; step < 1000; ++step) {
    const hbp::BroadPhaseUpdate& u = bp.update();
    const std::vector<Pair> want = brute_pairs(objs, boxes, bp);
    ASSERT_EQ(u.pairs, want) << "step " << step;
    ASSERT_EQ(u.created, minus(want, previous)) << "step " << step;
    ASSERT_EQ(u.removed, minus(previous, want)) << "step " << step;
    if (step == 0 && expect_no_events) {
      EXPECT_TRUE(u.created.empty());
      EXPECT_TRUE(u.removed.empty());
    }
    previous = want;
    std::vector<Handle> mh;
    std::vector<Aabb> mb;
    std::vector<char> taken(objs.size(), 0);
    for (int m = 0; m < 10; ++m) {
      const std::size_t i = pick(rng);
      if (taken[i]) continue;
      taken[i] = 1;
      Aabb b = boxes[i];
      const float d = jitter(rng);
      b.min[m % 3] += d;
      b.max[m % 3] += d;
      mh.push_back(objs[i].h);
      mb.push_back(b);
      boxes[i] = b;
    }
    bp.move(mh, mb);
    if (step == 500) {  // a second shift in the middle of the run
      bp.shift_origin({-offset[0], 0, 0});
      for (Aabb& b : boxes) {
        b.min[0] = b.min[0] + offset[0];
        b.max[0] = b.max[0] + offset[0];
      }
    }
  }
}

TEST(BroadPhaseLargeWorld, ShiftOriginFloatExact) {
  // x coordinates in [256, 1024], the others shifted by 0: every x - 512 is
  // exact (Sterbenz), so the shift changes no overlap and reports no event.
  for (unsigned threads : {1u, 2u}) run_float_shift(512.0f, 40.0f, {512.0f, 0, 0}, threads, true, 11 + threads);
}

TEST(BroadPhaseLargeWorld, ShiftOriginFloatRounded) {
  // At 1e6 the float spacing is 0.0625 and the offset is not a multiple of
  // it: the shifted boxes round, and the pairs follow the rounded boxes.
  for (unsigned threads : {1u, 2u})
    run_float_shift(1.0e6f, 30.0f, {999999.7f, 0.3f, -0.1f}, threads, false, 21 + threads);
}

TEST(BroadPhaseLargeWorld, ShiftOriginDouble) {
  std::mt19937_64 rng(5);
  for (unsigned threads : {1u, 2u}) {
    BroadPhase bp({.threads = threads, .double_precision = true});
    const std::array<double, 3> centre{1e9, 2e8, -3e7};
    std::vector<Object> objs;
    std::vector<AabbD> boxes;
    for (int i = 0; i < 200; ++i) {
      const AabbD b = random_box(rng, centre, 20);
      const bool is_static = i % 4 == 0;
      objs.push_back({bp.add(b, {.is_static = is_static}), is_static, 0});
      boxes.push_back(b);
    }
    const std::vector<Pair> before = bp.update().pairs;
    ASSERT_EQ(before, brute_pairs(objs, boxes, bp));
    // A power-of-two offset near the boxes: x - offset is exact in double.
    bp.shift_origin_d({1073741824.0, 268435456.0, -33554432.0});
    const hbp::BroadPhaseUpdate& u = bp.update();
    EXPECT_EQ(u.pairs, before);
    EXPECT_TRUE(u.created.empty());
    EXPECT_TRUE(u.removed.empty());
    EXPECT_EQ(bp.box_d(objs[0].h).min[0], boxes[0].min[0] - 1073741824.0);
    // Near the origin now: the float boxes are much tighter; a float offset works too.
    bp.shift_origin({0.5f, 0, 0});
    for (AabbD& b : boxes) {
      for (int k = 0; k < 3; ++k) {
        const double off[3] = {1073741824.0 + 0.5, 268435456.0, -33554432.0};
        b.min[k] = b.min[k] - off[k];
        b.max[k] = b.max[k] - off[k];
      }
    }
    // (Each shift is one double subtraction; both shifts here are exact,
    // so subtracting their sum gives the same boxes.)
    const hbp::BroadPhaseUpdate& v = bp.update();
    EXPECT_EQ(v.pairs, brute_pairs(objs, boxes, bp));
    for (std::size_t i = 0; i < objs.size(); ++i) ASSERT_EQ(bp.box_d(objs[i].h).max, boxes[i].max);
  }
}

TEST(BroadPhaseLargeWorld, InvalidInputChangesNothing) {
  const double nan = std::numeric_limits<double>::quiet_NaN();
  const double inf = std::numeric_limits<double>::infinity();
  BroadPhase f({.threads = 1});
  BroadPhase d({.threads = 1, .double_precision = true});
  const Aabb fb{{0, 0, 0}, {1, 1, 1}};
  const AabbD db{{0, 0, 0}, {1, 1, 1}};
  // Float boxes on a double BroadPhase and double boxes on a float one.
  EXPECT_THROW(d.add(fb), hbp::InvalidInput);
  EXPECT_THROW(d.add(std::vector<Aabb>{fb}), hbp::InvalidInput);
  EXPECT_THROW(f.add(db), hbp::InvalidInput);
  EXPECT_THROW(f.add(std::vector<AabbD>{db}), hbp::InvalidInput);
  const Handle hf = f.add(fb);
  const Handle hd = d.add(db);
  EXPECT_THROW(d.move(std::vector<Handle>{hd}, std::vector<Aabb>{fb}), hbp::InvalidInput);
  EXPECT_THROW(f.move(std::vector<Handle>{hf}, std::vector<AabbD>{db}), hbp::InvalidInput);
  EXPECT_THROW(d.box(hd), hbp::InvalidInput);
  EXPECT_THROW(f.box_d(hf), hbp::InvalidInput);
  EXPECT_THROW(f.query_box(db), hbp::InvalidInput);
  EXPECT_EQ(f.size(), 1u);
  EXPECT_EQ(d.size(), 1u);
  // Malformed double boxes, named by row; nothing added.
  try {
    d.add(std::vector<AabbD>{db, {{0, nan, 0}, {1, 1, 1}}});
    FAIL();
  } catch (const hbp::InvalidInput& e) {
    EXPECT_NE(std::string(e.what()).find("row 1"), std::string::npos) << e.what();
  }
  EXPECT_THROW(d.add(AabbD{{0, 0, 0}, {inf, 1, 1}}), hbp::InvalidInput);
  EXPECT_THROW(d.add(AabbD{{2, 0, 0}, {1, 1, 1}}), hbp::InvalidInput);
  EXPECT_EQ(d.size(), 1u);
  // A batch with a stale handle moves nothing.
  const Handle gone = d.add(db);
  d.remove(std::vector<Handle>{gone});
  const AabbD far{{5, 5, 5}, {6, 6, 6}};
  EXPECT_THROW(d.move(std::vector<Handle>{hd, gone}, std::vector<AabbD>{far, far}), hbp::InvalidInput);
  EXPECT_EQ(d.box_d(hd).min, db.min);
  EXPECT_THROW(d.move(std::vector<Handle>{hd}, std::vector<AabbD>{far, far}), hbp::InvalidInput);
  // Non-finite offsets, and shifts past the float range: nothing applied.
  for (BroadPhase* bp : {&f, &d}) {
    EXPECT_THROW(bp->shift_origin({std::numeric_limits<float>::quiet_NaN(), 0, 0}), hbp::InvalidInput);
    EXPECT_THROW(bp->shift_origin({0, std::numeric_limits<float>::infinity(), 0}), hbp::InvalidInput);
    EXPECT_THROW(bp->shift_origin_d({0, 0, nan}), hbp::InvalidInput);
  }
  EXPECT_THROW(f.shift_origin_d({1e300, 0, 0}), hbp::InvalidInput);
  const Handle huge = f.add(Aabb{{3e38f, 0, 0}, {3.2e38f, 1, 1}});
  EXPECT_THROW(f.shift_origin({-1e38f, 0, 0}), hbp::InvalidInput);
  EXPECT_EQ(f.box(huge).max[0], 3.2e38f);
  EXPECT_EQ(f.box(hf).min[0], 0.0f);
  const Handle dhuge = d.add(AabbD{{1e308, 0, 0}, {1.5e308, 1, 1}});
  EXPECT_THROW(d.shift_origin_d({-1e308, 0, 0}), hbp::InvalidInput);
  EXPECT_EQ(d.box_d(dhuge).max[0], 1.5e308);
  EXPECT_EQ(d.box_d(hd).min, db.min);
  // double_precision is BroadPhase's alone.
  EXPECT_THROW(hbp::HybridBroadPhase({.double_precision = true}), hbp::InvalidInput);
  // Beyond the float range a double box still works (its float box clamps).
  const Handle dnear = d.add(AabbD{{1.2e308, 0, 0}, {1.3e308, 1, 1}});
  EXPECT_EQ(d.update().pairs, (std::vector<Pair>{{std::min(dhuge, dnear), std::max(dhuge, dnear)}}));
  d.add(AabbD{{1.55e308, 0, 0}, {1.7e308, 1, 1}});  // beyond dhuge, one float box with it
  d.add(AabbD{{-1.7e308, 0, 0}, {-1.6e308, 1, 1}});
  d.add(AabbD{{-1.5e308, 0, 0}, {-1.55e308 / 2, 1, 1}});
  EXPECT_EQ(d.update().pairs.size(), 1u);
}

}  // namespace
