// SPDX-License-Identifier: MIT
// Functional equivalence of both microarchitecture models with the oracle,
// the bit-level float32 comparators, capacity limits and the cell-engine
// adapters.
#include <gtest/gtest.h>

#include <cmath>
#include <limits>
#include <random>
#include <string>
#include <vector>

#include "hbp/brute_force.hpp"
#include "hbp/error.hpp"
#include "hbp/hw/analytic_cycles.hpp"
#include "hbp/hw/area_efficient_model.hpp"
#include "hbp/hw/float_comparator.hpp"
#include "hbp/hw/hardware_order_pairs.hpp"
#include "hbp/hw/hw_cell_engines.hpp"
#include "hbp/hw/many_object_model.hpp"
#include "hbp/scenario.hpp"

namespace {

using hbp::hw::Design;
using hbp::hw::ModelConfig;

std::vector<hbp::Pair> run_model(Design d, const ModelConfig& cfg, const hbp::BoxArray& boxes) {
  std::vector<hbp::Pair> pairs;
  if (d == Design::AreaEfficient) {
    hbp::hw::AreaEfficientModel(cfg).run(boxes, pairs);
  } else {
    hbp::hw::ManyObjectModel(cfg).run(boxes, pairs);
  }
  return pairs;
}

void expect_oracle_pairs(const hbp::BoxArray& boxes, const std::string& what) {
  const std::vector<hbp::Pair> expected = hbp::brute_force_pairs(boxes);
  for (Design d : {Design::AreaEfficient, Design::ManyObject}) {
    for (std::uint32_t m : {1u, 4u, 16u}) {
      ModelConfig cfg;
      cfg.m = m;
      cfg.depth = 2048;
      std::vector<hbp::Pair> got = run_model(d, cfg, boxes);
      for (const hbp::Pair& p : got) ASSERT_LT(p.a, p.b) << what;
      EXPECT_EQ(hbp::canonicalize(got), 0u) << what << ": a pair written twice";
      const hbp::PairSetDiff diff = hbp::diff_pairs(expected, got);
      EXPECT_TRUE(diff.empty()) << what << " " << hbp::hw::design_name(d) << " m=" << m << ": "
                                << diff.summary();
    }
  }
}

hbp::BoxArray scenario_boxes(hbp::ScenarioKind kind, std::uint32_t n, std::uint64_t seed) {
  hbp::ScenarioParams p;
  p.kind = kind;
  p.n = n;
  p.seed = seed;
  hbp::Scenario s(p);
  s.step();
  hbp::BoxArray boxes;
  s.compute_boxes(boxes);
  return boxes;
}

TEST(HwFunctional, PaperScenarioMatchesOracle) {
  const hbp::BoxArray boxes = scenario_boxes(hbp::ScenarioKind::Paper, 700, 3);
  ASSERT_GT(hbp::brute_force_pairs(boxes).size(), 100u);  // the test has pairs to find
  expect_oracle_pairs(boxes, "paper scene");
}

TEST(HwFunctional, ClusteredScenarioMatchesOracle) {
  expect_oracle_pairs(scenario_boxes(hbp::ScenarioKind::Clustered, 500, 5), "clustered scene");
}

TEST(HwFunctional, DegenerateScenarioMatchesOracle) {
  expect_oracle_pairs(scenario_boxes(hbp::ScenarioKind::Degenerate, 400, 7), "degenerate scene");
}

TEST(HwFunctional, HandPickedDegenerateBoxes) {
  const float inf = std::numeric_limits<float>::infinity();
  const float denorm = std::numeric_limits<float>::denorm_min();
  hbp::BoxArray boxes;
  boxes.push_back({{0, 0, 0}, {1, 1, 1}});            // 0
  boxes.push_back({{1, 0, 0}, {2, 1, 1}});            // 1: face contact with 0
  boxes.push_back({{1, 1, 1}, {1, 1, 1}});            // 2: zero size at 0's corner
  boxes.push_back({{0, 0, 0}, {1, 1, 1}});            // 3: identical to 0
  boxes.push_back({{-1, -1, -1}, {-0.0f, -0.0f, -0.0f}});  // 4: touches 0 at -0 == +0
  boxes.push_back({{0.0f, 5, 5}, {0.0f, 6, 6}});      // 5: flat, far in y/z
  boxes.push_back({{-2, -2, -2}, {-denorm, -denorm, -denorm}});  // 6: just misses 0
  boxes.push_back({{-inf, -inf, -inf}, {inf, inf, inf}});        // 7: everything
  boxes.push_back({{2.0f, 0.5f, 0.5f}, {3.0f, 0.5f, 0.5f}});     // 8: touches 1's face edge
  boxes.push_back({{1.0000001f, 0, 0}, {2, 1, 1}});   // 9: one ulp clear of 0
  expect_oracle_pairs(boxes, "hand-picked");
  const std::vector<hbp::Pair> got = run_model(Design::AreaEfficient, {}, boxes);
  auto has = [&](std::uint32_t a, std::uint32_t b) {
    for (const hbp::Pair& p : got) {
      if (p.a == a && p.b == b) return true;
    }
    return false;
  };
  EXPECT_TRUE(has(0, 1));
  EXPECT_TRUE(has(0, 2));
  EXPECT_TRUE(has(0, 3));
  EXPECT_TRUE(has(0, 4));
  EXPECT_FALSE(has(0, 6));
  EXPECT_TRUE(has(4, 6));
  EXPECT_TRUE(has(1, 8));
  EXPECT_FALSE(has(0, 9));
  for (std::uint32_t i = 0; i < 7; ++i) EXPECT_TRUE(has(i, 7)) << i;
}

TEST(HwFunctional, FloatComparatorsFollowIeee754) {
  const float inf = std::numeric_limits<float>::infinity();
  std::vector<float> values = {0.0f, -0.0f, 1.0f, -1.0f, inf, -inf,
                               std::numeric_limits<float>::denorm_min(),
                               -std::numeric_limits<float>::denorm_min(),
                               std::numeric_limits<float>::min(), -std::numeric_limits<float>::min(),
                               std::numeric_limits<float>::max(), -std::numeric_limits<float>::max(),
                               1.0000001f, 0.99999994f, -1.0000001f, 3.5f, -3.5f};
  std::mt19937 rng(11);
  std::uniform_int_distribution<std::uint32_t> bits;
  while (values.size() < 400) {
    const float f = std::bit_cast<float>(bits(rng));
    if (!std::isnan(f)) values.push_back(f);
  }
  for (float a : values) {
    for (float b : values) {
      const std::uint32_t ab = hbp::hw::f32_bits(a), bb = hbp::hw::f32_bits(b);
      ASSERT_EQ(hbp::hw::f32_greater_equal(ab, bb), a >= b) << a << " >= " << b;
      ASSERT_EQ(hbp::hw::f32_less_equal(ab, bb), a <= b) << a << " <= " << b;
    }
  }
  EXPECT_TRUE(hbp::hw::f32_greater_equal(hbp::hw::f32_bits(-0.0f), hbp::hw::f32_bits(0.0f)));
  EXPECT_TRUE(hbp::hw::f32_less_equal(hbp::hw::f32_bits(0.0f), hbp::hw::f32_bits(-0.0f)));
}

TEST(HwFunctional, NanIsRejectedNamingTheObject) {
  hbp::BoxArray boxes;
  boxes.push_back({{0, 0, 0}, {1, 1, 1}});
  boxes.push_back({{0, std::nanf(""), 0}, {1, 1, 1}});
  std::vector<hbp::Pair> pairs;
  try {
    hbp::hw::ManyObjectModel().run(boxes, pairs);
    FAIL() << "NaN accepted";
  } catch (const hbp::InvalidInput& e) {
    EXPECT_NE(std::string(e.what()).find("object 1 has a NaN min y"), std::string::npos) << e.what();
  }
}

hbp::BoxArray unit_boxes(std::uint32_t n) {
  hbp::BoxArray boxes;
  for (std::uint32_t i = 0; i < n; ++i) {
    const float x = static_cast<float>(i);
    boxes.push_back({{x, 0, 0}, {x + 0.5f, 1, 1}});
  }
  return boxes;
}

TEST(HwFunctional, CapacityIsDepthForAreaEfficientAndDepthTimesMForManyObject) {
  ModelConfig cfg;
  cfg.m = 4;
  cfg.depth = 8;
  hbp::hw::AreaEfficientModel ae(cfg);
  hbp::hw::ManyObjectModel mo(cfg);
  EXPECT_EQ(ae.capacity(), 8u);
  EXPECT_EQ(mo.capacity(), 32u);
  std::vector<hbp::Pair> pairs;
  EXPECT_NO_THROW(ae.run(unit_boxes(8), pairs));
  EXPECT_NO_THROW(mo.run(unit_boxes(32), pairs));
  EXPECT_THROW(ae.run(unit_boxes(9), pairs), hbp::CapacityExceeded);
  try {
    mo.run(unit_boxes(33), pairs);
    FAIL() << "33 objects accepted by a 32-object buffer";
  } catch (const hbp::CapacityExceeded& e) {
    const std::string msg = e.what();
    EXPECT_NE(msg.find("many-object"), std::string::npos) << msg;
    EXPECT_NE(msg.find("at most 32"), std::string::npos) << msg;
    EXPECT_NE(msg.find("33"), std::string::npos) << msg;
  }
  // The paper's configuration: 1024 and 16,384.
  EXPECT_EQ(hbp::hw::AreaEfficientModel().capacity(), 1024u);
  EXPECT_EQ(hbp::hw::ManyObjectModel().capacity(), 16384u);
}

TEST(HwFunctional, FastPathGivesTheHardwareOrder) {
  const hbp::BoxArray boxes = scenario_boxes(hbp::ScenarioKind::Paper, 300, 9);
  for (std::uint32_t m : {1u, 3u, 16u}) {
    ModelConfig cfg;
    cfg.m = m;
    std::vector<hbp::Pair> fast;
    hbp::hw::area_efficient_order_pairs(boxes, fast);
    EXPECT_EQ(fast, run_model(Design::AreaEfficient, cfg, boxes)) << "m=" << m;
    fast.clear();
    hbp::hw::many_object_order_pairs(boxes, m, fast);
    EXPECT_EQ(fast, run_model(Design::ManyObject, cfg, boxes)) << "m=" << m;
  }
}

TEST(HwFunctional, CellEnginesAgreeBetweenFastAndSimulatedPaths) {
  const hbp::BoxArray boxes = scenario_boxes(hbp::ScenarioKind::Paper, 500, 13);
  const std::vector<hbp::Pair> expected = hbp::brute_force_pairs(boxes);
  for (Design d : {Design::AreaEfficient, Design::ManyObject}) {
    auto make = d == Design::AreaEfficient ? hbp::hw::make_area_efficient_engine
                                           : hbp::hw::make_many_object_engine;
    auto fast = make({}, false);
    auto sim = make({}, true)->clone();
    std::vector<hbp::Pair> fast_pairs, sim_pairs;
    const hbp::CellRun fast_run = fast->find_pairs(boxes, fast_pairs);
    const hbp::CellRun sim_run = sim->find_pairs(boxes, sim_pairs);
    EXPECT_EQ(fast_pairs, sim_pairs);
    EXPECT_EQ(fast_run.cycles, sim_run.cycles);
    EXPECT_EQ(fast_run.cycles, fast->cycles_for(500));
    EXPECT_EQ(fast->cycles_for(500), hbp::hw::analytic_cycles(d, 500, {}).total());
    std::vector<hbp::Pair> sorted = fast_pairs;
    hbp::canonicalize(sorted);
    EXPECT_EQ(sorted, expected);
    EXPECT_EQ(fast->default_cell_limit(), 1024u);
    EXPECT_EQ(fast->clock_hz(), 500e6);
    EXPECT_EQ(fast->capacity(), d == Design::AreaEfficient ? 1024u : 16384u);
    EXPECT_EQ(sim->name(), d == Design::AreaEfficient ? "ae-sim" : "mo-sim");
  }
}

TEST(HwFunctional, CellEnginesRefuseOversizedCells) {
  ModelConfig cfg;
  cfg.depth = 4;
  cfg.m = 2;
  for (bool simulate : {false, true}) {
    std::vector<hbp::Pair> pairs;
    EXPECT_THROW(hbp::hw::make_area_efficient_engine(cfg, simulate)->find_pairs(unit_boxes(5), pairs),
                 hbp::CapacityExceeded);
    EXPECT_NO_THROW(hbp::hw::make_many_object_engine(cfg, simulate)->find_pairs(unit_boxes(8), pairs));
    EXPECT_THROW(hbp::hw::make_many_object_engine(cfg, simulate)->find_pairs(unit_boxes(9), pairs),
                 hbp::CapacityExceeded);
  }
}

}  // namespace
