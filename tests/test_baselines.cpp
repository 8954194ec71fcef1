// SPDX-License-Identifier: MIT
// Every baseline (Bullet DBVT with and without deferred collide, Bullet
// AxisSweep3, CGAL, FCL's four broad-phase managers, ODE's three spaces, brute
// force) must find exactly the oracle's pair set,
// frame by frame: on the paper's scene and on adversarial ones (touching
// faces, identical boxes, zero-size boxes, boxes sliding into and out of
// contact). A mismatch prints the pairs that differ.
#include <gtest/gtest.h>

#include <cstdint>
#include <functional>
#include <string>
#include <vector>

#include "hbp/baselines/baseline.hpp"
#include "hbp/brute_force.hpp"
#include "hbp/error.hpp"
#include "hbp/scenario.hpp"

namespace {

using hbp::Aabb;
using hbp::BoxArray;
using hbp::Pair;
using hbp::baselines::Baseline;
using hbp::baselines::make_baseline;

class EveryBaseline : public ::testing::TestWithParam<std::string> {};

// Compares the baseline's exact pairs with the oracle's for this frame.
void expect_exact(Baseline& b, const BoxArray& boxes, const std::string& where) {
  const std::vector<Pair> expected = hbp::brute_force_pairs(boxes);
  const std::vector<Pair>& actual = b.exact_pairs();
  const hbp::PairSetDiff diff = hbp::diff_pairs(expected, actual);
  EXPECT_TRUE(diff.empty()) << b.name() << " " << where << ": " << diff.summary() << " (expected "
                            << expected.size() << " pairs)";
  // Whatever a baseline reports raw is at least the exact set.
  EXPECT_GE(b.raw_pairs(), actual.size()) << b.name() << " " << where;
}

// Runs a baseline through frames produced by `make_frame(k, boxes)`.
void run_frames(const std::string& name, std::uint32_t frames,
                const std::function<void(std::uint32_t, BoxArray&)>& make_frame, const std::string& scene) {
  auto b = make_baseline(name);
  BoxArray boxes;
  make_frame(0, boxes);
  b->setup(boxes);
  expect_exact(*b, boxes, scene + " setup");
  for (std::uint32_t k = 1; k < frames; ++k) {
    make_frame(k, boxes);
    b->update(boxes);
    expect_exact(*b, boxes, scene + " frame " + std::to_string(k));
  }
}

void run_scenario(const std::string& name, hbp::ScenarioKind kind, std::uint32_t n, std::uint64_t seed,
                  std::uint32_t frames, std::uint32_t steps_per_frame = 1) {
  hbp::ScenarioParams p;
  p.kind = kind;
  p.n = n;
  p.seed = seed;
  hbp::Scenario scenario(p);
  const std::string scene = std::string(hbp::scenario_kind_name(kind)) + " n=" + std::to_string(n) +
                            " seed=" + std::to_string(seed);
  run_frames(name, frames, [&](std::uint32_t k, BoxArray& boxes) {
    if (k > 0) {
      for (std::uint32_t s = 0; s < steps_per_frame; ++s) scenario.step();
    }
    scenario.compute_boxes(boxes);
  }, scene);
}

TEST_P(EveryBaseline, PaperSceneMatchesOracleEveryFrame) {
  for (std::uint64_t seed : {0u, 1u, 2u}) run_scenario(GetParam(), hbp::ScenarioKind::Paper, 400, seed, 4);
}

TEST_P(EveryBaseline, LargerPaperSceneWithBigStepsMatchesOracle) {
  // Ten steps per frame: boxes move far between updates, so incremental
  // structures (DBVT leaves, sweep-and-prune edges) must move a lot.
  run_scenario(GetParam(), hbp::ScenarioKind::Paper, 2000, 7, 4, 10);
}

TEST_P(EveryBaseline, ClusteredAndDegenerateScenesMatchOracle) {
  run_scenario(GetParam(), hbp::ScenarioKind::Clustered, 600, 3, 3);
  run_scenario(GetParam(), hbp::ScenarioKind::Degenerate, 500, 4, 4);
}

// Every object on one plane (a 2D world in 3D: quadtrees and sweeps see all
// objects at one z) and a few objects spanning most of the world (they sit
// in a tree's root, a hash space's top level, many grid cells).
TEST_P(EveryBaseline, FlatAndHugeScenesMatchOracle) {
  run_scenario(GetParam(), hbp::ScenarioKind::Flat, 600, 5, 3);
  run_scenario(GetParam(), hbp::ScenarioKind::Huge, 600, 6, 3);
}

// Unit cubes on an integer lattice: every neighbour (face, edge or corner)
// touches exactly, with no overlap of positive volume.
BoxArray lattice(int nx, int ny, int nz) {
  BoxArray boxes;
  for (int x = 0; x < nx; ++x)
    for (int y = 0; y < ny; ++y)
      for (int z = 0; z < nz; ++z) {
        const float fx = static_cast<float>(x), fy = static_cast<float>(y), fz = static_cast<float>(z);
        boxes.push_back({{fx, fy, fz}, {fx + 1, fy + 1, fz + 1}});
      }
  return boxes;
}

TEST_P(EveryBaseline, TouchingFacesEdgesAndCornersCount) {
  const BoxArray boxes = lattice(5, 5, 4);
  run_frames(GetParam(), 1, [&](std::uint32_t, BoxArray& out) { out = boxes; }, "lattice");
  // Each cube touches its 26-neighbourhood: for every offset (dx, dy, dz) in
  // {-1,0,1}^3 \ 0 there are (5-|dx|)(5-|dy|)(4-|dz|) placements; each pair is
  // counted from both ends. Fixed here so a broken oracle cannot hide a
  // broken baseline.
  std::size_t expected = 0;
  for (int dx = -1; dx <= 1; ++dx)
    for (int dy = -1; dy <= 1; ++dy)
      for (int dz = -1; dz <= 1; ++dz)
        if (dx || dy || dz)
          expected += static_cast<std::size_t>((5 - (dx != 0)) * (5 - (dy != 0)) * (4 - (dz != 0)));
  expected /= 2;
  EXPECT_EQ(expected, 795u);
  auto b = make_baseline(GetParam());
  b->setup(boxes);
  EXPECT_EQ(b->exact_pairs().size(), expected);
}

BoxArray identical_and_zero_size() {
  BoxArray boxes;
  for (int i = 0; i < 12; ++i) boxes.push_back({{2, 2, 2}, {3, 3, 3}});       // 12 identical: 66 pairs
  for (int i = 0; i < 5; ++i) boxes.push_back({{10, 10, 10}, {10, 10, 10}});  // 5 identical points: 10
  boxes.push_back({{3, 2.5f, 2.5f}, {3, 2.5f, 2.5f}});    // a point on a face of the 12: 12
  boxes.push_back({{3, 3, 3}, {3, 3, 3}});                // a point on their corner: 12 (+ next)
  boxes.push_back({{3, 3, 3}, {4, 4, 4}});                // a box touching their corner: 12 (+ point)
  boxes.push_back({{-1, 2.5f, 2.5f}, {5, 2.5f, 2.5f}});   // a segment through them: 12 + face point
  boxes.push_back({{20, 20, 20}, {21, 21, 21}});          // alone
  boxes.push_back({{3.0000002f, 3, 3}, {4, 4, 4}});       // one ulp clear of the 12: corner box only
  return boxes;
}

TEST_P(EveryBaseline, IdenticalAndZeroSizeBoxes) {
  const BoxArray boxes = identical_and_zero_size();
  run_frames(GetParam(), 1, [&](std::uint32_t, BoxArray& out) { out = boxes; }, "identical/zero-size");
  auto b = make_baseline(GetParam());
  b->setup(boxes);
  // 66 + 10 + 12 (face point) + 13 (corner point: the 12, the corner box)
  // + 12 (corner box: the 12) + 13 (segment: the 12, the face point)
  // + 1 (ulp box: the corner box) = 127.
  EXPECT_EQ(b->exact_pairs().size(), 127u);
}

// Two rows of boxes sliding past each other in exact steps of 1/4: pairs go
// from apart to touching to overlapping to touching to apart, exercising the
// incremental pair caches' add and remove paths on exact contacts.
TEST_P(EveryBaseline, SlidingIntoAndOutOfContact) {
  run_frames(GetParam(), 40, [](std::uint32_t k, BoxArray& boxes) {
    boxes.clear();
    const float shift = 0.25f * static_cast<float>(k);
    for (int i = 0; i < 16; ++i) {
      const float x = 2.0f * static_cast<float>(i);
      boxes.push_back({{x, 0, 0}, {x + 1, 1, 1}});                   // fixed row
      boxes.push_back({{x - 6 + shift, 1, 0}, {x - 5 + shift, 2, 1}});  // sliding row, touching in y
      boxes.push_back({{x + 1, 5 - shift / 4, 0}, {x + 2, 6 - shift / 4, 1}});  // descending onto the row
    }
  }, "sliding");
}

TEST_P(EveryBaseline, SetupAgainStartsAFreshWorld) {
  auto b = make_baseline(GetParam());
  BoxArray first, second;
  for (int i = 0; i < 10; ++i) first.push_back({{0, 0, 0}, {1, 1, 1}});
  for (int i = 0; i < 4; ++i) {
    const float x = 3.0f * static_cast<float>(i);
    second.push_back({{x, 0, 0}, {x + 1, 1, 1}});
  }
  b->setup(first);
  EXPECT_EQ(b->exact_pairs().size(), 45u);
  b->setup(second);
  EXPECT_TRUE(b->exact_pairs().empty()) << hbp::diff_pairs({}, b->exact_pairs()).summary();
  second.set(1, {{1, 0, 0}, {2, 1, 1}});  // touches box 0
  b->update(second);
  EXPECT_EQ(b->exact_pairs(), (std::vector<Pair>{{0, 1}}));
}

INSTANTIATE_TEST_SUITE_P(Baselines, EveryBaseline, ::testing::ValuesIn(hbp::baselines::baseline_names()),
                         [](const auto& info) {
                           std::string s = info.param;
                           for (auto& c : s)
                             if (c == '-') c = '_';
                           return s;
                         });

TEST(BaselineRegistry, UnknownNameListsKnownOnes) {
  try {
    make_baseline("bullet-gpu");
    FAIL() << "expected InvalidInput";
  } catch (const hbp::InvalidInput& e) {
    const std::string msg = e.what();
    EXPECT_NE(msg.find("bullet-gpu"), std::string::npos) << msg;
    EXPECT_NE(msg.find("bullet-axis-sweep"), std::string::npos) << msg;
  }
}

TEST(BaselineRegistry, NamesAndLabels) {
  EXPECT_EQ(make_baseline("bullet-dbvt")->label(), "Bullet DBVT");
  EXPECT_EQ(make_baseline("bullet-dbvt-deferred")->name(), "bullet-dbvt-deferred");
  EXPECT_EQ(make_baseline("fcl-dynamic-aabb-tree")->label(), "FCL DynamicAABBTree");
  EXPECT_EQ(make_baseline("ode-quadtree")->label(), "ODE quadtree");
  EXPECT_EQ(hbp::baselines::baseline_names().size(), 12u);
  // Every name the registry lists makes a baseline that answers to it.
  for (const auto& name : hbp::baselines::baseline_names()) EXPECT_EQ(make_baseline(name)->name(), name);
}

// Bullet's pair cache is a superset: after a large move the DBVT keeps
// fattened leaves, so raw counts may exceed exact ones, never the reverse,
// and the filtered set still equals the oracle's.
TEST(BulletDbvt, RawIsSupersetAfterMotion) {
  hbp::ScenarioParams p;
  p.n = 1500;
  hbp::Scenario s(p);
  BoxArray boxes;
  s.compute_boxes(boxes);
  auto b = make_baseline("bullet-dbvt");
  b->setup(boxes);
  std::size_t raw_minus_exact = 0;
  for (int k = 0; k < 10; ++k) {
    s.step();
    s.compute_boxes(boxes);
    b->update(boxes);
    expect_exact(*b, boxes, "frame " + std::to_string(k));
    raw_minus_exact += b->raw_pairs() - b->exact_pairs().size();
  }
  EXPECT_GT(raw_minus_exact, 0u) << "fattened leaves should leave some non-overlapping pairs in the cache";
}

}  // namespace
