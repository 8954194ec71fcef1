// SPDX-License-Identifier: MIT
// Verilator testbench: the RTL of both microarchitectures against the C++
// cycle-accurate models (hbp::hw::AreaEfficientModel / ManyObjectModel, the
// reference), the oracle, the paper's cycle formulas and Tables 1 and 3:
// same pairs in the same order, each written in the same cycle, same port
// addresses every cycle, same cycle counts by phase. Each Verilated build (hbp_rtl_models.hpp) is one typed
// test instance. HBP_RTL_SWEEP=1 enables the larger *Sweep* tests.
#include <gtest/gtest.h>

#include <algorithm>
#include <chrono>
#include <cstdio>
#include <bit>
#include <cmath>
#include <cstdint>
#include <cstdlib>
#include <limits>
#include <random>
#include <vector>

#include "hbp/brute_force.hpp"
#include "hbp/hw/area_efficient_model.hpp"
#include "hbp/hw/many_object_model.hpp"
#include "hbp_rtl_models.hpp"
#include "rtl_cycles.hpp"

namespace hbp::rtl {
namespace {

// ------------------------------------------------------------------ inputs
BoxArray random_boxes(std::size_t n, std::uint32_t seed, float world, float lo, float hi) {
  std::mt19937 rng(seed);
  std::uniform_real_distribution<float> pos(-world, world), size(lo, hi);
  BoxArray b(n);
  for (std::size_t i = 0; i < n; ++i) {
    Aabb a;
    for (int k = 0; k < 3; ++k) {
      a.min[k] = pos(rng);
      a.max[k] = a.min[k] + size(rng);
    }
    b.set(i, a);
  }
  return b;
}

// Few tight clusters: many pairs, many equal coordinates.
BoxArray clustered_boxes(std::size_t n, std::uint32_t seed) {
  std::mt19937 rng(seed);
  std::uniform_real_distribution<float> centre(-100.f, 100.f), jitter(-2.f, 2.f), size(0.f, 3.f);
  float cx[4][3];
  for (auto& c : cx)
    for (float& v : c) v = centre(rng);
  BoxArray b(n);
  for (std::size_t i = 0; i < n; ++i) {
    Aabb a;
    const auto& c = cx[rng() % 4];
    for (int k = 0; k < 3; ++k) {
      a.min[k] = std::round(c[k] + jitter(rng));  // integers: exact touches
      a.max[k] = a.min[k] + std::round(size(rng));
    }
    b.set(i, a);
  }
  return b;
}

// Touching faces, zero-size boxes, identical boxes, -0 against +0,
// subnormals, huge values, negative coordinates.
BoxArray degenerate_boxes(std::size_t n, std::uint32_t seed) {
  std::mt19937 rng(seed);
  const float vals[] = {-0.f, 0.f, 1.f, -1.f, 2.f, 1e-45f, -1e-45f, 3.4e38f, -3.4e38f, 0.5f};
  BoxArray b(n);
  for (std::size_t i = 0; i < n; ++i) {
    Aabb a;
    for (int k = 0; k < 3; ++k) {
      float x = vals[rng() % 10], y = vals[rng() % 10];
      if (y < x) std::swap(x, y);
      if (rng() % 4 == 0) y = x;  // zero extent (and -0 vs +0 when x is a zero)
      a.min[k] = x;
      a.max[k] = y;
    }
    if (i % 7 == 3) a = b.get(i - 1);  // identical boxes
    b.set(i, a);
  }
  return b;
}

// ----------------------------------------------------------- expectations
// The order in which each design emits pairs: area-efficient by (i, j);
// many-object by (row a = i div m, offset k = j - i, lane i mod m).
std::vector<Pair> expected_order(Design d, unsigned m, std::vector<Pair> pairs) {
  if (d == Design::kManyObject) {
    std::stable_sort(pairs.begin(), pairs.end(), [m](const Pair& x, const Pair& y) {
      const auto kx = std::make_tuple(x.a / m, x.b - x.a, x.a % m);
      const auto ky = std::make_tuple(y.a / m, y.b - y.a, y.a % m);
      return kx < ky;
    });
  }
  return pairs;
}

// What the C++ model of the same configuration does with the same boxes.
struct ModelRun {
  std::vector<Pair> pairs;
  std::vector<std::uint64_t> pair_cycle;  // issue cycle + pipeline depth
  std::vector<std::vector<std::uint32_t>> port_a, port_b, selector;  // per issuing cycle
  std::vector<std::uint64_t> issue_cycle;
  hw::Counters counters;
  std::uint64_t load_cycles = 0;  // count_load, one AABB per cycle (the RTL's bus)
  std::uint32_t depth = 0;
};

// `with_trace`: record the model's per-cycle trace (memory grows with the
// cycle count: off for the largest sweeps, which then skip the per-line cycle
// and address checks).
template <class Model>
ModelRun run_model(const BoxArray& boxes, bool with_trace) {
  hw::ModelConfig cfg;
  cfg.m = Model::m;
  cfg.depth = Model::depth;
  ModelRun out;
  hw::ModelConfig load_cfg = cfg;
  load_cfg.count_load = true;
  load_cfg.load_aabbs_per_cycle = 1;
  if constexpr (Model::design == Design::kAreaEfficient) {
    hw::AreaEfficientModel model(cfg);
    hw::AreaEfficientTrace trace;
    out.counters = model.run(boxes, out.pairs, with_trace ? &trace : nullptr);
    out.depth = model.pipeline_depth();
    out.load_cycles = hw::AreaEfficientModel(load_cfg).analytic_cycles(boxes.size()).load;
    for (const auto& c : trace) {
      out.issue_cycle.push_back(c.cycle);
      std::vector<std::uint32_t> a, b;
      for (unsigned g = 0; g < Model::m; ++g) {
        a.push_back(c.port_address[2 * g]);
        b.push_back(c.port_address[2 * g + 1]);
      }
      out.port_a.push_back(a);
      out.port_b.push_back(b);
      for (const auto& s : c.comparisons)
        if (s.valid && s.collided) out.pair_cycle.push_back(c.cycle + out.depth);
    }
  } else {
    hw::ManyObjectModel model(cfg);
    hw::ManyObjectTrace trace;
    out.counters = model.run(boxes, out.pairs, with_trace ? &trace : nullptr);
    out.depth = model.pipeline_depth();
    out.load_cycles = hw::ManyObjectModel(load_cfg).analytic_cycles(boxes.size()).load;
    for (const auto& c : trace) {
      out.issue_cycle.push_back(c.cycle);
      out.port_a.push_back(c.a_address);
      out.port_b.push_back(c.b_address);
      out.selector.push_back(c.selector);
      for (const auto& s : c.comparisons)
        if (s.valid && s.collided) out.pair_cycle.push_back(c.cycle + out.depth);
    }
  }
  return out;
}

template <class Model>
void check_run(const BoxArray& boxes, const char* what, bool read_memory = true,
               bool use_model = true) {
  SCOPED_TRACE(std::string(Model::name) + " " + what + " n=" + std::to_string(boxes.size()));
  RtlDriver<typename Model::V> drv(Model::design, Model::m, Model::depth);
  drv.set_pair_rows(Model::pair_rows);
  const bool trace = boxes.size() <= 400;
  const RtlResult r = drv.run(boxes, read_memory, trace);
  const auto n = static_cast<std::uint32_t>(boxes.size());
  const std::vector<Pair> oracle = brute_force_pairs(boxes);
  const std::vector<Pair> want = expected_order(Model::design, Model::m, oracle);

  // The oracle's pairs, in the design's order.
  ASSERT_EQ(r.pairs.size(), want.size());
  for (std::size_t k = 0; k < want.size(); ++k) {
    ASSERT_EQ(r.pairs[k], want[k]) << "line " << k;
  }
  // Cycle counters = paper formula + restarts + drain (closed form).
  const std::uint64_t seq = sequence_cycles(Model::design, n, Model::m);
  const std::uint64_t lat = pipeline_latency(Model::design);
  EXPECT_EQ(r.cyc_load, n);
  EXPECT_EQ(r.cyc_seq, seq);
  EXPECT_EQ(r.cyc_restart, restart_cycles(Model::design, n, Model::m));
  EXPECT_EQ(r.cyc_drain, seq ? lat : 0u);
  EXPECT_EQ(r.cycles, total_cycles(Model::design, n, Model::m));
  EXPECT_EQ(r.cycles_to_done, seq ? r.cycles + 1 : 2u);  // done rises after the drain

  if (use_model) {
    // The C++ model, cycle for cycle.
    const bool model_trace = boxes.size() <= 2048;
    const ModelRun mr = run_model<Model>(boxes, model_trace);
    EXPECT_EQ(mr.depth, lat);
    ASSERT_EQ(r.pairs, mr.pairs);
    if (model_trace) {
      ASSERT_EQ(r.pair_cycle, mr.pair_cycle);  // each line written in the same cycle
    }
    EXPECT_EQ(r.cyc_seq, mr.counters.cycles.sequence);
    EXPECT_EQ(r.cyc_restart, mr.counters.cycles.restart);
    EXPECT_EQ(r.cyc_drain, mr.counters.cycles.drain);
    EXPECT_EQ(r.cycles, mr.counters.cycles.total());
    EXPECT_EQ(r.cyc_load, mr.load_cycles);
    EXPECT_EQ(r.memory_count, mr.counters.pairs_written);
    if (trace) {
      ASSERT_EQ(r.trace.size(), mr.issue_cycle.size());
      const std::uint32_t amask = Model::depth - 1;  // RTL addresses wrap past DEPTH
      for (std::size_t c = 0; c < r.trace.size(); ++c) {
        ASSERT_EQ(r.trace[c].cycle, mr.issue_cycle[c]) << "step " << c;
        for (unsigned g = 0; g < Model::m; ++g) {
          ASSERT_EQ(r.trace[c].port_a[g] & amask, mr.port_a[c][g] & amask) << "cycle " << r.trace[c].cycle;
          ASSERT_EQ(r.trace[c].port_b[g] & amask, mr.port_b[c][g] & amask) << "cycle " << r.trace[c].cycle;
          if (Model::design == Design::kManyObject) {
            ASSERT_EQ(r.trace[c].selector[g], mr.selector[c][g]) << "cycle " << r.trace[c].cycle;
          }
        }
      }
    }
  }
  // The pair memory holds the same lines in the same order.
  EXPECT_EQ(r.memory_count, want.size());
  const std::uint64_t cap = std::uint64_t{Model::pair_rows} * drv.lanes();
  EXPECT_EQ(r.memory_overflow, want.size() > cap);
  if (read_memory) {
    ASSERT_EQ(r.memory_pairs.size(), std::min<std::uint64_t>(want.size(), cap));
    for (std::size_t k = 0; k < r.memory_pairs.size(); ++k) {
      ASSERT_EQ(r.memory_pairs[k], want[k]) << "memory line " << k;
    }
  }
}

template <class Model>
class RtlDesign : public ::testing::Test {};
using Models = ::testing::Types<models::ae_m1, models::ae_m2, models::ae_m4, models::ae_m16,
                                models::mo_m1, models::mo_m2, models::mo_m4, models::mo_m16>;
class ModelNames {
 public:
  template <class T>
  static std::string GetName(int) { return T::name; }
};
TYPED_TEST_SUITE(RtlDesign, Models, ModelNames);

std::uint32_t capacity_of(Design d, unsigned m, unsigned depth) {
  return d == Design::kAreaEfficient ? depth : depth * m;
}

TYPED_TEST(RtlDesign, TinyCountsIncludingEmpty) {
  using M = TypeParam;
  for (std::uint32_t n : {0u, 1u, 2u, 3u, 5u, 2 * M::m, 2 * M::m + 1, 3 * M::m + 2}) {
    check_run<M>(clustered_boxes(n, 7 + n), "tiny");
  }
}

TYPED_TEST(RtlDesign, RandomSparseAndDense) {
  using M = TypeParam;
  const std::uint32_t cap = capacity_of(M::design, M::m, M::depth);
  const std::uint32_t big = std::min<std::uint32_t>(cap, 300);
  check_run<M>(random_boxes(big, 1, 200.f, 1.f, 30.f), "random-sparse");
  check_run<M>(random_boxes(std::min<std::uint32_t>(cap, 97), 2, 20.f, 1.f, 30.f), "random-dense");
}

TYPED_TEST(RtlDesign, ClusteredAndDegenerate) {
  using M = TypeParam;
  const std::uint32_t cap = capacity_of(M::design, M::m, M::depth);
  check_run<M>(clustered_boxes(std::min<std::uint32_t>(cap, 120), 3), "clustered");
  check_run<M>(degenerate_boxes(std::min<std::uint32_t>(cap, 90), 4), "degenerate");
}

TYPED_TEST(RtlDesign, FullCapacity) {
  using M = TypeParam;
  const std::uint32_t cap = capacity_of(M::design, M::m, M::depth);
  if (cap > 1024) GTEST_SKIP() << "capacity " << cap << ": in rtl-sweep";
  check_run<M>(random_boxes(cap, 5, 150.f, 1.f, 40.f), "full");
}

TYPED_TEST(RtlDesign, PairMemoryOverflowKeepsFirstLines) {
  using M = TypeParam;
  // All boxes identical: n(n-1)/2 lines; more than the memory holds.
  const std::uint64_t lines = std::uint64_t{M::pair_rows} * (M::design == Design::kAreaEfficient ? 2 * M::m - 1 : M::m);
  std::uint32_t n = 2;
  while (std::uint64_t{n} * (n - 1) / 2 <= lines) ++n;
  if (n > capacity_of(M::design, M::m, M::depth) || n > 600) GTEST_SKIP() << "needs n=" << n;
  BoxArray b(n);
  for (std::uint32_t i = 0; i < n; ++i) b.set(i, Aabb{{0.f, -0.f, 1.f}, {1.f, 0.f, 1.f}});
  check_run<M>(b, "overflow");
}

TYPED_TEST(RtlDesign, Sweep) {
  using M = TypeParam;
  if (!std::getenv("HBP_RTL_SWEEP")) GTEST_SKIP() << "set HBP_RTL_SWEEP=1 (target rtl-sweep)";
  const std::uint32_t cap = capacity_of(M::design, M::m, M::depth);
  std::vector<std::uint32_t> ns;
  for (std::uint32_t n = 1; n < 64; ++n) ns.push_back(n);
  for (std::uint32_t n = 64; n <= cap; n = n * 3 / 2) ns.push_back(n);
  ns.push_back(cap);
  for (std::uint32_t n : ns) {
    const bool memory = n <= 2048;
    check_run<M>(random_boxes(n, n, std::cbrt(125000.f * 5 * n) / 2, 25.f, 75.f), "paper-scene", memory);
    if (n <= 1024) check_run<M>(clustered_boxes(n, n + 1), "clustered", memory);
    if (n <= 1024) check_run<M>(degenerate_boxes(n, n + 2), "degenerate", memory);
  }
}

// ------------------------------------------------------ paper Tables 1, 3
BoxArray far_apart(std::size_t n) {
  BoxArray b(n);
  for (std::size_t i = 0; i < n; ++i) {
    const float x = 10.f * static_cast<float>(i);
    b.set(i, Aabb{{x, 0, 0}, {x + 1, 1, 1}});
  }
  return b;
}

TEST(RtlPaper, Table1AreaEfficientSequence) {
  // m = 4, n = 10: 11 cycles; port 0A then ports 0B, 1A, 1B, ... 3B.
  RtlDriver<models::ae_m4::V> drv(Design::kAreaEfficient, 4, models::ae_m4::depth);
  const RtlResult r = drv.run(far_apart(10), false, true);
  const std::uint32_t table[11][2] = {{0, 1}, {0, 8}, {1, 2}, {1, 9}, {2, 3}, {3, 4},
                                      {4, 5}, {5, 6}, {6, 7}, {7, 8}, {8, 9}};
  ASSERT_EQ(r.trace.size(), 11u);
  for (std::size_t c = 0; c < 11; ++c) {
    EXPECT_EQ(r.trace[c].cycle, c + 1);  // one step per cycle, no gaps
    EXPECT_EQ(r.trace[c].port_a[0], table[c][0]) << "cycle " << c + 1;
    // ports 0B, 1A, 1B, ...: consecutive from 0B (addresses >= 10 are removed)
    EXPECT_EQ(r.trace[c].port_b[0], table[c][1]);
    for (unsigned g = 1; g < 4; ++g) {
      EXPECT_EQ(r.trace[c].port_a[g], table[c][1] + 2 * g - 1);
      EXPECT_EQ(r.trace[c].port_b[g], table[c][1] + 2 * g);
    }
  }
  EXPECT_EQ(r.cyc_seq, 11u);
}

TEST(RtlPaper, Table3ManyObjectSequence) {
  // m = 4, n = 10: 15 cycles; A address, B addresses, multiplexer selectors.
  RtlDriver<models::mo_m4::V> drv(Design::kManyObject, 4, models::mo_m4::depth);
  const RtlResult r = drv.run(far_apart(10), false, true);
  struct Row {
    std::uint32_t a, b[4], sel[4];
  };
  const Row table[15] = {
      {0, {1, 0, 0, 0}, {1, 2, 3, 0}}, {0, {1, 1, 0, 0}, {2, 3, 0, 1}},
      {0, {1, 1, 1, 0}, {3, 0, 1, 2}}, {0, {1, 1, 1, 1}, {0, 1, 2, 3}},
      {0, {2, 1, 1, 1}, {1, 2, 3, 0}}, {0, {2, 2, 1, 1}, {2, 3, 0, 1}},
      {0, {2, 2, 2, 1}, {3, 0, 1, 2}}, {0, {2, 2, 2, 2}, {0, 1, 2, 3}},
      {0, {3, 2, 2, 2}, {1, 2, 3, 0}}, {1, {2, 1, 1, 1}, {1, 2, 3, 0}},
      {1, {2, 2, 1, 1}, {2, 3, 0, 1}}, {1, {2, 2, 2, 1}, {3, 0, 1, 2}},
      {1, {2, 2, 2, 2}, {0, 1, 2, 3}}, {1, {3, 2, 2, 2}, {1, 2, 3, 0}},
      {2, {3, 2, 2, 2}, {1, 2, 3, 0}}};
  ASSERT_EQ(r.trace.size(), 15u);
  for (std::size_t c = 0; c < 15; ++c) {
    for (unsigned g = 0; g < 4; ++g) {
      EXPECT_EQ(r.trace[c].port_a[g], table[c].a) << "cycle " << c + 1 << " group " << g;
      EXPECT_EQ(r.trace[c].port_b[g], table[c].b[g]) << "cycle " << c + 1 << " group " << g;
      EXPECT_EQ(r.trace[c].selector[g], table[c].sel[g]) << "cycle " << c + 1 << " group " << g;
    }
  }
  EXPECT_EQ(r.cyc_seq, 15u);
  // Two row changes, each holding the sequencer one pipeline depth (7).
  EXPECT_EQ(r.cyc_restart, 14u);
  EXPECT_EQ(r.trace[9].cycle, 10u + 7u);
  EXPECT_EQ(r.trace[14].cycle, 15u + 14u);
}

TEST(RtlPaper, SequenceFormulasMatchTheTables) {
  EXPECT_EQ(ae_sequence_cycles(10, 4), 11u);
  EXPECT_EQ(mo_sequence_cycles(10, 4), 15u);
  EXPECT_EQ(ae_sequence_cycles(1, 16), 0u);
  EXPECT_EQ(mo_sequence_cycles(1, 16), 0u);
  EXPECT_EQ(ae_sequence_cycles(2, 1), 1u);
  EXPECT_EQ(mo_sequence_cycles(5, 4), 4u + 0u);  // rows: 4 steps, then a row of one object
}

TEST(RtlInterface, LoadPastCapacityIsDroppedAndFlagged) {
  auto ctx = std::make_unique<VerilatedContext>();
  models::ae_m1::V top(ctx.get(), "top");
  auto tick = [&] {
    top.clk = 1;
    top.eval();
    top.clk = 0;
    top.eval();
  };
  top.rst = 1;
  tick();
  top.rst = 0;
  top.load_valid = 1;
  for (unsigned k = 0; k < models::ae_m1::depth + 3; ++k) tick();
  top.load_valid = 0;
  tick();
  EXPECT_EQ(top.n_loaded, models::ae_m1::depth);
  EXPECT_TRUE(top.load_error);
  EXPECT_EQ(top.cyc_load, models::ae_m1::depth);
  top.clear = 1;
  tick();
  top.clear = 0;
  EXPECT_EQ(top.n_loaded, 0u);
  EXPECT_FALSE(top.load_error);
  top.final();
}

// ---------------------------------------------------- float comparator
float from_bits(std::uint32_t u) { return std::bit_cast<float>(u); }

TEST(RtlComparator, MatchesIeeeLessOrEqualOnSpecialAndRandomValues) {
  auto ctx = std::make_unique<VerilatedContext>();
  Vhbp_fcmp cmp(ctx.get(), "fcmp");
  const std::uint32_t special[] = {0x00000000u, 0x80000000u, 0x00000001u, 0x80000001u,
                                   0x007fffffu, 0x807fffffu, 0x00800000u, 0x3f800000u,
                                   0xbf800000u, 0x7f7fffffu, 0xff7fffffu, 0x7f800000u,
                                   0xff800000u, 0x7fc00000u, 0xffc00000u, 0x7f800001u,
                                   0xff800001u, 0x3f800001u, 0x3f7fffffu, 0x40000000u};
  std::vector<std::uint32_t> vals(std::begin(special), std::end(special));
  std::mt19937 rng(11);
  for (int k = 0; k < 300; ++k) vals.push_back(static_cast<std::uint32_t>(rng()));
  std::size_t checked = 0, nan_cases = 0;
  for (std::uint32_t a : vals) {
    for (std::uint32_t b : vals) {
      cmp.a = a;
      cmp.b = b;
      cmp.eval();
      const float fa = from_bits(a), fb = from_bits(b);
      ASSERT_EQ(static_cast<bool>(cmp.le), fa <= fb) << std::hex << a << " <= " << b;
      nan_cases += std::isnan(fa) || std::isnan(fb);
      ++checked;
    }
  }
  EXPECT_GT(nan_cases, 1000u);  // NaN: always false, as IEEE / C++
  EXPECT_EQ(checked, vals.size() * vals.size());
  // -0 == +0 both ways
  cmp.a = 0x80000000u;
  cmp.b = 0x00000000u;
  cmp.eval();
  EXPECT_TRUE(cmp.le);
  cmp.a = 0x00000000u;
  cmp.b = 0x80000000u;
  cmp.eval();
  EXPECT_TRUE(cmp.le);
  cmp.final();
}

TEST(RtlBoxes, NaNCoordinateNeverOverlapsLikeTheCppTest) {
  // The library rejects NaN before engines; the RTL still matches overlaps().
  BoxArray b(4);
  const float nan = std::numeric_limits<float>::quiet_NaN();
  b.set(0, Aabb{{0, 0, 0}, {1, 1, 1}});
  b.set(1, Aabb{{nan, 0, 0}, {1, 1, 1}});
  b.set(2, Aabb{{0, 0, 0}, {1, nan, 1}});
  b.set(3, Aabb{{0.5f, 0.5f, 0.5f}, {2, 2, 2}});
  // (The C++ models reject NaN when loading, so only the oracle here.)
  check_run<models::ae_m2>(b, "nan", true, false);
  check_run<models::mo_m2>(b, "nan", true, false);
}

}  // namespace
}  // namespace hbp::rtl

// ------------------------------------------------ rtl-ae / rtl-mo engines
#include "hbp/cell_engine.hpp"
#include "hbp/error.hpp"
#include "hbp/hybrid_broadphase.hpp"
#include "hbp/rtl/rtl_engines.hpp"

namespace hbp::rtl {
namespace {

TEST(RtlEngines, RegisteredAndEqualToTheOracle) {
  register_rtl_engines();
  register_rtl_engines();  // idempotent
  for (const char* name : {"rtl-ae", "rtl-mo"}) {
    SCOPED_TRACE(name);
    std::unique_ptr<CellEngine> e = make_cell_engine(name);
    ASSERT_NE(e, nullptr);
    EXPECT_EQ(e->name(), name);
    EXPECT_EQ(e->capacity(), std::string(name) == "rtl-ae" ? 1024u : 16384u);
    EXPECT_EQ(e->clock_hz(), 500e6);
    const BoxArray cell = random_boxes(200, 9, 60.f, 1.f, 20.f);
    std::vector<Pair> pairs = {{7, 9}};  // appends
    const CellRun run = e->find_pairs(cell, pairs);
    ASSERT_FALSE(pairs.empty());
    EXPECT_EQ(pairs.front(), (Pair{7, 9}));
    pairs.erase(pairs.begin());
    EXPECT_EQ(run.cycles, e->cycles_for(200));
    EXPECT_GT(run.cycles, 0u);
    sort_pairs(pairs);
    EXPECT_EQ(pairs, brute_force_pairs(cell));
    // A clone is an independent RTL instance.
    std::unique_ptr<CellEngine> c = e->clone();
    std::vector<Pair> again;
    EXPECT_EQ(c->find_pairs(cell, again).cycles, run.cycles);
    sort_pairs(again);
    EXPECT_EQ(again, pairs);
  }
  // Same modelled cycles as the C++ model engines "ae" / "mo".
  for (std::uint32_t n : {0u, 1u, 2u, 100u, 1000u}) {
    EXPECT_EQ(make_cell_engine("rtl-ae")->cycles_for(n), make_cell_engine("ae")->cycles_for(n)) << n;
    EXPECT_EQ(make_cell_engine("rtl-mo")->cycles_for(n), make_cell_engine("mo")->cycles_for(n)) << n;
  }
  std::unique_ptr<CellEngine> ae = make_cell_engine("rtl-ae");
  std::vector<Pair> out;
  EXPECT_THROW(ae->find_pairs(random_boxes(1025, 1, 10.f, 1.f, 2.f), out), CapacityExceeded);
}

// The pair limit stops a run within one cycle's lines (2m - 1 or m) of it.
TEST(RtlEngines, StopAtThePairLimit) {
  register_rtl_engines();
  BoxArray cell(300);
  for (std::uint32_t i = 0; i < 300; ++i) cell.set(i, {{0, 0, 0}, {1, 1, 1}});  // 44,850 pairs
  for (const char* name : {"rtl-ae", "rtl-mo"}) {
    SCOPED_TRACE(name);
    std::unique_ptr<CellEngine> e = make_cell_engine(name);
    e->set_pair_limit(5000);
    std::vector<Pair> out = {{7, 9}};
    EXPECT_THROW(e->find_pairs(cell, out), CapacityExceeded);
    EXPECT_LE(out.size(), 1u);  // nothing appended by the failed call
    e->set_pair_limit(300 * 299 / 2);
    out.clear();
    e->find_pairs(cell, out);
    EXPECT_EQ(out.size(), 300u * 299 / 2);
  }
}

TEST(RtlEngines, HybridSystemWithTheHardwareInTheLoop) {
  // The whole hybrid system (k-d partition -> RTL -> de-duplication) on a
  // frame several cells large: the oracle's pairs, and the same modelled
  // cycles as with the C++ model engines on the same cells.
  register_rtl_engines();
  const BoxArray boxes = random_boxes(3000, 21, 400.f, 5.f, 40.f);
  const std::vector<Pair> oracle = brute_force_pairs(boxes);
  for (const auto& [rtl, model] : {std::pair{"rtl-ae", "ae"}, std::pair{"rtl-mo", "mo"}}) {
    SCOPED_TRACE(rtl);
    BroadPhaseOptions opt;
    opt.engine = rtl;
    opt.cell_limit = 512;
    opt.threads = 2;
    HybridBroadPhase hw(opt);
    EXPECT_EQ(hw.update(boxes), oracle);
    const FrameStats rtl_stats = hw.stats();
    EXPECT_GT(rtl_stats.cells, 4u);
    opt.engine = model;
    HybridBroadPhase ref(opt);
    EXPECT_EQ(ref.update(boxes), oracle);
    EXPECT_EQ(rtl_stats.modelled_cycles, ref.stats().modelled_cycles);
    EXPECT_GT(rtl_stats.modelled_cycles, 0u);
  }
}

TEST(RtlEngines, FullCellSimulationSpeed) {
  // One 1024-box cell through each m = 16 engine; prints simulated cycles/s.
  register_rtl_engines();
  const BoxArray cell = random_boxes(1024, 33, 300.f, 5.f, 40.f);
  for (const char* name : {"rtl-ae", "rtl-mo"}) {
    std::unique_ptr<CellEngine> e = make_cell_engine(name);
    std::vector<Pair> pairs;
    const auto t0 = std::chrono::steady_clock::now();
    const CellRun run = e->find_pairs(cell, pairs);
    const double s = std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
    EXPECT_EQ(run.cycles, e->cycles_for(1024));
    sort_pairs(pairs);
    EXPECT_EQ(pairs, brute_force_pairs(cell));
    std::printf("%s: n=1024, %llu cycles (+1024 load) in %.3f s: %.2f M simulated cycles/s\n", name,
                static_cast<unsigned long long>(run.cycles), s,
                static_cast<double>(run.cycles + 1024) / s / 1e6);
  }
}

}  // namespace
}  // namespace hbp::rtl
