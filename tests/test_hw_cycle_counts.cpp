// SPDX-License-Identifier: MIT
// The cycle-level simulations against the analytic cycle functions, over
// many (n, m) and every timing option, plus the pipeline's timing details.
#include <gtest/gtest.h>

#include <random>
#include <vector>

#include "hbp/box_array.hpp"
#include "hbp/error.hpp"
#include "hbp/hw/analytic_cycles.hpp"
#include "hbp/hw/area_efficient_model.hpp"
#include "hbp/hw/many_object_model.hpp"

namespace {

using hbp::hw::CycleBreakdown;
using hbp::hw::Design;
using hbp::hw::ModelConfig;

hbp::BoxArray random_boxes(std::uint32_t n, std::uint32_t seed) {
  std::mt19937 rng(seed);
  std::uniform_real_distribution<float> pos(0.0f, 20.0f), size(0.0f, 3.0f);
  hbp::BoxArray boxes;
  for (std::uint32_t i = 0; i < n; ++i) {
    hbp::Aabb b;
    for (int a = 0; a < 3; ++a) {
      b.min[a] = pos(rng);
      b.max[a] = b.min[a] + size(rng);
    }
    boxes.push_back(b);
  }
  return boxes;
}

std::vector<ModelConfig> timing_variants(std::uint32_t m) {
  std::vector<ModelConfig> v;
  ModelConfig base;
  base.m = m;
  base.depth = 600;
  v.push_back(base);
  ModelConfig with_load = base;
  with_load.count_load = true;
  with_load.load_aabbs_per_cycle = 3;
  v.push_back(with_load);
  ModelConfig no_row_drain = base;
  no_row_drain.row_change_drains_pipeline = false;
  v.push_back(no_row_drain);
  ModelConfig zero_latency = base;
  zero_latency.latency = {0, 0, 0, 0, 0};
  v.push_back(zero_latency);
  return v;
}

void expect_model_matches_analytic(Design d, const ModelConfig& cfg, std::uint32_t n) {
  const hbp::BoxArray boxes = random_boxes(n, n * 131 + cfg.m);
  std::vector<hbp::Pair> pairs;
  hbp::hw::Counters k;
  if (d == Design::AreaEfficient) {
    hbp::hw::AreaEfficientModel model(cfg);
    k = model.run(boxes, pairs);
  } else {
    hbp::hw::ManyObjectModel model(cfg);
    k = model.run(boxes, pairs);
  }
  const hbp::hw::Counters a = hbp::hw::analytic_counters(d, n, cfg);
  const auto where = ::testing::Message() << hbp::hw::design_name(d) << " n=" << n << " m=" << cfg.m
                                          << " load=" << cfg.count_load
                                          << " row_drain=" << cfg.row_change_drains_pipeline
                                          << " depth=" << hbp::hw::pipeline_depth(d, cfg);
  EXPECT_EQ(k.cycles.load, a.cycles.load) << where;
  EXPECT_EQ(k.cycles.sequence, a.cycles.sequence) << where;
  EXPECT_EQ(k.cycles.restart, a.cycles.restart) << where;
  EXPECT_EQ(k.cycles.drain, a.cycles.drain) << where;
  EXPECT_EQ(k.comparator_slots, a.comparator_slots) << where;
  EXPECT_EQ(k.comparisons_performed, a.comparisons_performed) << where;
  EXPECT_EQ(k.comparisons_discarded, a.comparisons_discarded) << where;
  EXPECT_EQ(k.pairs_written, pairs.size()) << where;
}

TEST(HwCycleCounts, SimulationEqualsAnalyticForEverySmallNAndM) {
  for (Design d : {Design::AreaEfficient, Design::ManyObject}) {
    for (std::uint32_t m : {1u, 2u, 3u, 4u, 5u, 7u, 8u, 16u}) {
      for (const ModelConfig& cfg : timing_variants(m)) {
        for (std::uint32_t n = 0; n <= 70; ++n) expect_model_matches_analytic(d, cfg, n);
      }
    }
  }
}

TEST(HwCycleCounts, SimulationEqualsAnalyticForLargerAndBoundaryN) {
  for (Design d : {Design::AreaEfficient, Design::ManyObject}) {
    for (std::uint32_t m : {3u, 16u, 31u, 64u}) {
      ModelConfig cfg;
      cfg.m = m;
      for (std::uint32_t n : {2 * m - 1, 2 * m, 2 * m + 1, 4 * m - 2, 4 * m - 1, 7 * m + 2, 301u, 1024u}) {
        expect_model_matches_analytic(d, cfg, n);
      }
    }
  }
}

TEST(HwCycleCounts, PhasesOfThePaperConfiguration) {
  const ModelConfig cfg;  // m = 16, 500 MHz, pipeline depth 6 / 7
  EXPECT_EQ(hbp::hw::pipeline_depth(Design::AreaEfficient, cfg), 6u);
  EXPECT_EQ(hbp::hw::pipeline_depth(Design::ManyObject, cfg), 7u);
  const CycleBreakdown ae = hbp::hw::analytic_cycles(Design::AreaEfficient, 1000, cfg);
  EXPECT_EQ(ae, (CycleBreakdown{0, 16599, 0, 6}));
  // 63 rows, each followed by a 7-cycle drain (the last one is the final drain).
  const CycleBreakdown mo = hbp::hw::analytic_cycles(Design::ManyObject, 1000, cfg);
  EXPECT_EQ(mo, (CycleBreakdown{0, 31689, 62 * 7, 7}));
  ModelConfig with_load = cfg;
  with_load.count_load = true;
  // Replicated buffer: 2 AABBs per cycle; many-object: interface width 2.
  EXPECT_EQ(hbp::hw::analytic_cycles(Design::AreaEfficient, 1001, with_load).load, 501u);
  with_load.load_aabbs_per_cycle = 64;
  EXPECT_EQ(hbp::hw::load_aabbs_per_cycle(Design::AreaEfficient, with_load), 2u);
  EXPECT_EQ(hbp::hw::load_aabbs_per_cycle(Design::ManyObject, with_load), 32u);
  EXPECT_EQ(hbp::hw::analytic_cycles(Design::ManyObject, 1000, with_load).load, 32u);
}

TEST(HwCycleCounts, TrivialInputsTakeNoSequenceCycles) {
  for (std::uint32_t n : {0u, 1u}) {
    EXPECT_EQ(hbp::hw::analytic_cycles(Design::AreaEfficient, n, {}).total(), 0u);
    EXPECT_EQ(hbp::hw::analytic_cycles(Design::ManyObject, n, {}).total(), 0u);
  }
  // Two objects: one cycle, then the pipeline drains.
  EXPECT_EQ(hbp::hw::analytic_cycles(Design::AreaEfficient, 2, {}).total(), 1u + 6u);
  EXPECT_EQ(hbp::hw::analytic_cycles(Design::ManyObject, 2, {}).total(), 1u + 7u);
}

TEST(HwCycleCounts, RowChangeDrainShowsAsGapsInTheTrace) {
  ModelConfig cfg;
  cfg.m = 4;
  hbp::hw::ManyObjectModel model(cfg);
  std::vector<hbp::Pair> pairs;
  hbp::hw::ManyObjectTrace trace;
  model.run(random_boxes(10, 1), pairs, &trace);
  ASSERT_EQ(trace.size(), 15u);
  // Rows of 9, 5 and 1 cycles, each row change waiting 7 cycles.
  EXPECT_EQ(trace[8].cycle, 9u);
  EXPECT_EQ(trace[9].cycle, 17u);
  EXPECT_EQ(trace[13].cycle, 21u);
  EXPECT_EQ(trace[14].cycle, 29u);
}

TEST(HwCycleCounts, PairLinesAreWrittenOnePipelineDepthAfterIssue) {
  // Two overlapping boxes: the single line appears in the last cycle.
  hbp::BoxArray boxes;
  boxes.push_back({{0, 0, 0}, {1, 1, 1}});
  boxes.push_back({{1, 1, 1}, {2, 2, 2}});
  for (std::uint32_t depth : {0u, 1u, 5u}) {
    ModelConfig cfg;
    cfg.latency = {depth, 0, 0, 0, 0};
    hbp::hw::AreaEfficientModel model(cfg);
    std::vector<hbp::Pair> pairs;
    const hbp::hw::Counters k = model.run(boxes, pairs);
    EXPECT_EQ(k.cycles.total(), 1u + depth);
    EXPECT_EQ(k.cycles.drain, depth);
    ASSERT_EQ(pairs.size(), 1u);
    EXPECT_EQ(pairs[0], (hbp::Pair{0, 1}));
  }
}

TEST(HwCycleCounts, UtilisationApproachesOneForLargeN) {
  const ModelConfig cfg;
  const double ae_small = hbp::hw::analytic_counters(Design::AreaEfficient, 100, cfg).utilisation();
  const double ae_large = hbp::hw::analytic_counters(Design::AreaEfficient, 1024, cfg).utilisation();
  EXPECT_LT(ae_small, ae_large);
  EXPECT_GT(ae_large, 0.95);
  EXPECT_LE(ae_large, 1.0);
  const double mo = hbp::hw::analytic_counters(Design::ManyObject, 16384, cfg).utilisation();
  EXPECT_GT(mo, 0.999);
  EXPECT_LE(mo, 1.0);
}

TEST(HwCycleCounts, ConfigurationIsValidated) {
  ModelConfig bad;
  bad.m = 0;
  EXPECT_THROW(hbp::hw::AreaEfficientModel{bad}, hbp::InvalidInput);
  bad.m = 65;
  EXPECT_THROW(hbp::hw::ManyObjectModel{bad}, hbp::InvalidInput);
  ModelConfig no_depth;
  no_depth.depth = 0;
  EXPECT_THROW(hbp::hw::ManyObjectModel{no_depth}, hbp::InvalidInput);
  ModelConfig no_clock;
  no_clock.clock_hz = 0;
  EXPECT_THROW(hbp::hw::validate(no_clock), hbp::InvalidInput);
  try {
    hbp::hw::validate(bad);
    FAIL() << "m = 65 accepted";
  } catch (const hbp::InvalidInput& e) {
    EXPECT_NE(std::string(e.what()).find("m = 65"), std::string::npos) << e.what();
  }
}

}  // namespace
