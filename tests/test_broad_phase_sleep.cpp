// SPDX-License-Identifier: MIT
// BroadPhase::set_static (sleeping and waking) against the brute-force
// reference of broad_phase_session.hpp: long randomized runs mixing add,
// move, remove, set_static, set_layer and set_collides on 1 and 2 threads,
// every frame's pairs, events and stats checked, handles, kinds, boxes and
// layers checked across sleeps and wakes; plus the event rules of a kind
// change, its stats, and batches that throw changing nothing.
#include <gtest/gtest.h>

#include <string>
#include <vector>

#include "broad_phase_session.hpp"
#include "hbp/broad_phase.hpp"
#include "hbp/error.hpp"

namespace {

using hbp::Aabb;
using hbp::BroadPhase;
using hbp::Handle;
using hbp::Pair;
using hbp::test::Session;

// Box queries between edits and update() see the kinds as edited.
void check_query(Session& s) {
  const Aabb q = hbp::test::random_box(s.rng, s.world);
  std::vector<Handle> want;
  for (const auto& [h, o] : s.ref.objects)
    if (hbp::overlaps(o.box, q)) want.push_back(h);
  for (BroadPhase* bp : s.systems) ASSERT_EQ(bp->query_box(q), want) << "frame " << s.frame;
}

void run(unsigned seed, int frames, std::size_t target, float world) {
  BroadPhase one({.threads = 1}), two({.threads = 2});
  Session s(seed, world, {&one, &two});
  s.add(target / 2, false, 0);
  s.add(target / 4, true, 1);
  std::uint64_t sleeps = 0, wakes = 0;
  for (int f = 0; f < frames; ++f) {
    const std::size_t statics_before = one.stats().statics;
    s.random_edits(target);
    if (testing::Test::HasFatalFailure()) return;
    if (f % 7 == 3) check_query(s);
    if (testing::Test::HasFatalFailure()) return;
    s.check_frame();
    if (testing::Test::HasFatalFailure()) return;
    if (f % 50 == 0) s.check_objects();
    if (testing::Test::HasFatalFailure()) return;
    (one.stats().statics > statics_before ? sleeps : wakes) += one.stats().statics != statics_before;
  }
  // Not a vacuous run: pairs, events and both kinds of change happened.
  EXPECT_GT(s.pairs_seen, static_cast<std::uint64_t>(frames) * target / 8);
  EXPECT_GT(s.events_seen, static_cast<std::uint64_t>(frames));
  EXPECT_GT(sleeps, static_cast<std::uint64_t>(frames) / 20);
  EXPECT_GT(wakes, static_cast<std::uint64_t>(frames) / 20);
}

TEST(BroadPhaseSleep, RandomSleepWakeMatchesBruteForce) {
  for (unsigned seed = 1; seed <= 3; ++seed) {
    SCOPED_TRACE(seed);
    run(seed, 3000, 160, 14);
    if (HasFatalFailure()) return;
  }
}

// Enough objects for the parallel paths (several chunks of moving objects
// and of pairs) and a partition of many cells.
TEST(BroadPhaseSleep, LargerRandomSleepWakeMatchesBruteForce) { run(77, 150, 3000, 45); }

struct Scene {
  BroadPhase bp{{.threads = 2}};
  Handle a, b, c, floor;
  Scene() {
    a = bp.add(Aabb{{0, 0, 0}, {1, 1, 1}});
    b = bp.add(Aabb{{0.5f, 0, 0}, {1.5f, 1, 1}});
    c = bp.add(Aabb{{0, 0.5f, 0}, {1, 1.5f, 1}});
    floor = bp.add(Aabb{{-5, -1, -5}, {5, 0, 5}}, {.is_static = true});
    bp.update();
  }
};

// A sleeping object whose pairs are all with moving objects: every pair
// stays (one of its objects still moves), so no event.
TEST(BroadPhaseSleep, SleepWithOnlyMovingPartnersReportsNothing) {
  BroadPhase bp({.threads = 2});
  const Handle a = bp.add(Aabb{{0, 0, 0}, {1, 1, 1}});
  const Handle b = bp.add(Aabb{{0.5f, 0, 0}, {1.5f, 1, 1}});
  const Handle c = bp.add(Aabb{{0, 0.5f, 0}, {1, 1.5f, 1}});
  bp.add(Aabb{{9, 9, 9}, {10, 10, 10}}, {.is_static = true});  // statics exist, not near
  const std::vector<Pair> before = bp.update().pairs;
  ASSERT_EQ(before.size(), 3u);
  bp.set_static(std::vector<Handle>{a}, true);
  const hbp::BroadPhaseUpdate& u = bp.update();
  EXPECT_EQ(u.pairs, before);
  EXPECT_TRUE(u.created.empty());
  EXPECT_TRUE(u.removed.empty());
  EXPECT_TRUE(bp.is_static(a));
  EXPECT_FALSE(bp.is_static(b));
  // Waking it again: the same.
  bp.set_static(std::vector<Handle>{a}, false);
  const hbp::BroadPhaseUpdate& w = bp.update();
  EXPECT_EQ(w.pairs, before);
  EXPECT_TRUE(w.created.empty() && w.removed.empty());
  (void)c;
}

// A pair whose objects are both static after the change is removed, and
// created again when one of them wakes.
TEST(BroadPhaseSleep, PairOfTwoSleepersIsRemovedAndComesBackOnWake) {
  Scene s;
  ASSERT_EQ(s.bp.last_update().pairs.size(), 5u);  // a-b, a-c, b-c, a-floor, b-floor
  s.bp.set_static(std::vector<Handle>{s.a, s.b}, true);
  const hbp::BroadPhaseUpdate& u = s.bp.update();
  EXPECT_EQ(u.removed, (std::vector<Pair>{{s.a, s.b}, {s.a, s.floor}, {s.b, s.floor}}));
  EXPECT_TRUE(u.created.empty());
  EXPECT_EQ(u.pairs, (std::vector<Pair>{{s.a, s.c}, {s.b, s.c}}));
  s.bp.set_static(std::vector<Handle>{s.b}, false);
  const hbp::BroadPhaseUpdate& w = s.bp.update();
  EXPECT_EQ(w.created, (std::vector<Pair>{{s.a, s.b}, {s.b, s.floor}}));
  EXPECT_TRUE(w.removed.empty());
  // A static wall that starts to move: its pairs with static objects appear.
  s.bp.set_static(std::vector<Handle>{s.floor}, false);
  EXPECT_EQ(s.bp.update().created, (std::vector<Pair>{{s.a, s.floor}}));
}

TEST(BroadPhaseSleep, HandlesBoxesAndLayersSurviveSleepAndWake) {
  BroadPhase bp;
  const std::vector<Aabb> boxes = {{{0, 0, 0}, {1, 1, 1}}, {{3, 0, 0}, {4, 1, 1}}, {{6, 0, 0}, {7, 1, 1}}};
  const std::vector<Handle> h = bp.add(boxes, {.layer = 3});
  bp.update();
  bp.set_static(h, true);
  bp.move(std::vector<Handle>{h[1]}, std::vector<Aabb>{{{3, 1, 0}, {4, 2, 1}}});  // a sleeping body moved by hand
  for (int i = 0; i < 3; ++i) {
    EXPECT_TRUE(bp.contains(h[i]));
    EXPECT_TRUE(bp.is_static(h[i]));
    EXPECT_EQ(bp.layer(h[i]), 3);
  }
  bp.update();
  bp.set_static(std::vector<Handle>{h[1], h[2]}, false);
  bp.update();
  EXPECT_FALSE(bp.is_static(h[1]));
  EXPECT_TRUE(hbp::test::same_box(bp.box(h[1]), Aabb{{3, 1, 0}, {4, 2, 1}}));
  EXPECT_TRUE(hbp::test::same_box(bp.box(h[2]), boxes[2]));
  // New objects get new handles; the old ones still name their objects.
  const Handle d = bp.add(Aabb{{0, 0, 0}, {1, 1, 1}});
  EXPECT_EQ(bp.query_box(Aabb{{0, 0, 0}, {0.5f, 0.5f, 0.5f}}), (std::vector<Handle>{h[0], d}));
  EXPECT_EQ(bp.update().created, (std::vector<Pair>{{h[0], d}}));
}

TEST(BroadPhaseSleep, AlreadyOfTheKindIsANoOp) {
  Scene s;
  s.bp.set_static(std::vector<Handle>{s.a, s.b}, false);
  s.bp.set_static(std::vector<Handle>{s.floor}, true);
  const hbp::BroadPhaseUpdate& u = s.bp.update();
  EXPECT_TRUE(u.created.empty() && u.removed.empty());
  EXPECT_EQ(s.bp.stats().moved, 0u);
  EXPECT_EQ(s.bp.stats().static_changes, 0u);
}

TEST(BroadPhaseSleep, BadBatchThrowsNamingTheRowAndChangesNothing) {
  Scene s;
  const Handle gone = s.bp.add(Aabb{{20, 20, 20}, {21, 21, 21}});
  s.bp.remove(std::vector<Handle>{gone});
  s.bp.update();
  const auto expect_row = [&](const std::vector<Handle>& batch, bool is_static, const std::string& row) {
    try {
      s.bp.set_static(batch, is_static);
      ADD_FAILURE() << "no exception";
    } catch (const hbp::InvalidInput& e) {
      EXPECT_NE(std::string(e.what()).find("set_static: " + row), std::string::npos) << e.what();
    }
  };
  expect_row({s.a, s.b, gone}, true, "row 2");                 // stale
  expect_row({s.a, s.b, 12345}, true, "row 2");                // never used
  expect_row({s.floor, s.a, s.b, s.a}, false, "row 3");        // repeated
  EXPECT_FALSE(s.bp.is_static(s.a));
  EXPECT_FALSE(s.bp.is_static(s.b));
  EXPECT_TRUE(s.bp.is_static(s.floor));
  const hbp::BroadPhaseUpdate& u = s.bp.update();
  EXPECT_TRUE(u.created.empty() && u.removed.empty());
  EXPECT_EQ(s.bp.stats().moved + s.bp.stats().static_changes, 0u);
}

// Each counter counts an object at most once a frame, whatever the sequence
// of kind changes and moves.
TEST(BroadPhaseSleep, StatsCountKindChanges) {
  Scene s;
  const Aabb away{{30, 30, 30}, {31, 31, 31}};
  s.bp.set_static(std::vector<Handle>{s.a}, true);  // a sleeps: a static added
  s.bp.update();
  EXPECT_EQ(s.bp.stats().moved, 0u);
  EXPECT_EQ(s.bp.stats().static_changes, 1u);
  EXPECT_EQ(s.bp.stats().statics, 2u);
  EXPECT_EQ(s.bp.stats().moving, 2u);

  s.bp.set_static(std::vector<Handle>{s.floor}, false);  // the floor wakes: static removed, moving added
  s.bp.update();
  EXPECT_EQ(s.bp.stats().moved, 1u);
  EXPECT_EQ(s.bp.stats().static_changes, 1u);

  // b moves, sleeps, is moved asleep, wakes, sleeps: counted once in each.
  s.bp.move(std::vector<Handle>{s.b}, std::vector<Aabb>{away});
  s.bp.set_static(std::vector<Handle>{s.b}, true);
  s.bp.move(std::vector<Handle>{s.b}, std::vector<Aabb>{{{0, 0, 0}, {1, 1, 1}}});
  s.bp.set_static(std::vector<Handle>{s.b}, false);
  s.bp.set_static(std::vector<Handle>{s.b}, true);
  // a (static) moves, wakes: one static change, one moved.
  s.bp.move(std::vector<Handle>{s.a}, std::vector<Aabb>{away});
  s.bp.set_static(std::vector<Handle>{s.a}, false);
  s.bp.update();
  EXPECT_EQ(s.bp.stats().moved, 2u);
  EXPECT_EQ(s.bp.stats().static_changes, 2u);
}

// The whole-frame batch (every moving object, in handle order, first edit
// of the frame) followed by a sleep in the same frame.
TEST(BroadPhaseSleep, WholeFrameMoveThenSleep) {
  BroadPhase bp({.threads = 2});
  std::vector<Aabb> boxes;
  for (int i = 0; i < 40; ++i) boxes.push_back(Aabb{{float(i), 0, 0}, {float(i) + 1.5f, 1, 1}});
  const std::vector<Handle> h = bp.add(boxes);
  bp.update();
  for (Aabb& b : boxes) b.min[1] += 0.25f, b.max[1] += 0.25f;
  boxes[20] = Aabb{{100, 0, 0}, {101, 1, 1}};
  bp.move(h, boxes);  // every object changed
  bp.set_static(std::vector<Handle>{h[4], h[5], h[6]}, true);
  const hbp::BroadPhaseUpdate& u = bp.update();
  EXPECT_EQ(bp.stats().moved, 40u);
  EXPECT_EQ(bp.stats().static_changes, 3u);
  // 4-5 and 5-6 now static-static; 19-20 and 20-21 apart. 3-4 and 6-7 stay.
  EXPECT_EQ(u.removed, (std::vector<Pair>{{h[4], h[5]}, {h[5], h[6]}, {h[19], h[20]}, {h[20], h[21]}}));
  EXPECT_TRUE(u.created.empty());
  EXPECT_EQ(u.pairs.size(), 39u - 4u);
  for (int i : {4, 5, 6, 20}) EXPECT_TRUE(hbp::test::same_box(bp.box(h[i]), boxes[i])) << i;
}

}  // namespace
