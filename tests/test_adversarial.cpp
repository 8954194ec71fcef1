// SPDX-License-Identifier: MIT
// Adversarial scenes through the hybrid system, every frame of every scene
// checked against the oracle with each engine (sw, sw-allpairs, ae, mo, and
// small-buffer configurations of the two microarchitectures so that cells
// overflow the accelerator) and several cell limits.
//
// Running the binary directly (all tests in one process) prints the table
// of docs/robustness.md at the end.
#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <functional>
#include <limits>
#include <mutex>
#include <random>
#include <string>
#include <vector>

#include "hbp/brute_force.hpp"
#include "hbp/collision_pipeline.hpp"
#include "hbp/error.hpp"
#include "hbp/hw/hw_cell_engines.hpp"
#include "hbp/hybrid_broadphase.hpp"
#include "hbp/scenario.hpp"

namespace {

using hbp::Aabb;
using hbp::BoxArray;
using hbp::HybridBroadPhase;
using hbp::Pair;

constexpr float kMax = std::numeric_limits<float>::max();
constexpr float kDenormMin = std::numeric_limits<float>::denorm_min();

struct Scene {
  std::string name;
  std::vector<BoxArray> frames;
};

Aabb cube(float x, float y, float z, float side) { return {{x, y, z}, {x + side, y + side, z + side}}; }

BoxArray from(const std::vector<Aabb>& v) {
  BoxArray b;
  b.reserve(v.size());
  for (const Aabb& a : v) b.push_back(a);
  return b;
}

// ---- The scenes -------------------------------------------------------------

Scene identical() {
  std::vector<Aabb> v(600, Aabb{{1, 2, 3}, {4, 5, 6}});
  return {"all identical", {from(v), from(v)}};
}

Scene nested_concentric() {
  // Box i is [-(i+1), i+1]^3: every box contains every smaller one.
  std::vector<Aabb> v;
  for (int i = 0; i < 500; ++i) {
    const float r = static_cast<float>(i + 1);
    v.push_back({{-r, -r, -r}, {r, r, r}});
  }
  return {"nested concentric", {from(v)}};
}

Scene one_huge_box() {
  // One box spanning the world, 1999 small boxes inside it.
  std::mt19937 rng(1);
  std::uniform_real_distribution<float> pos(-100, 100), size(0.5f, 4);
  std::vector<Aabb> v{{{-1e4f, -1e4f, -1e4f}, {1e4f, 1e4f, 1e4f}}};
  for (int i = 0; i < 1999; ++i) v.push_back(cube(pos(rng), pos(rng), pos(rng), size(rng)));
  std::rotate(v.begin(), v.begin() + 1, v.begin() + 1000);  // the huge box in the middle of the ids
  return {"nested in one huge box", {from(v)}};
}

Scene single_plane() {
  // Flat boxes (zero thickness in z) on z = 0.
  std::mt19937 rng(2);
  std::uniform_real_distribution<float> pos(0, 100), size(0, 3);
  std::vector<Aabb> v;
  for (int i = 0; i < 2000; ++i) {
    const float x = pos(rng), y = pos(rng);
    v.push_back({{x, y, 0}, {x + size(rng), y + size(rng), 0}});
  }
  return {"single plane (z = 0)", {from(v)}};
}

Scene single_line() {
  // Segments on the x axis: y and z are 0 everywhere.
  std::mt19937 rng(3);
  std::uniform_real_distribution<float> pos(0, 1000), size(0, 2);
  std::vector<Aabb> v;
  for (int i = 0; i < 2000; ++i) {
    const float x = pos(rng);
    v.push_back({{x, 0, 0}, {x + size(rng), 0, 0}});
  }
  return {"single line (x axis)", {from(v)}};
}

Scene touching_lattice() {
  // 12^3 cubes sharing faces, edges and corners exactly; the second frame has
  // spacing 0.1 (not representable) with shared faces computed identically.
  std::vector<Aabb> a, b;
  for (int i = 0; i < 12; ++i)
    for (int j = 0; j < 12; ++j)
      for (int k = 0; k < 12; ++k) {
        a.push_back({{float(i), float(j), float(k)}, {float(i + 1), float(j + 1), float(k + 1)}});
        b.push_back({{float(i) * 0.1f, float(j) * 0.1f, float(k) * 0.1f},
                     {float(i + 1) * 0.1f, float(j + 1) * 0.1f, float(k + 1) * 0.1f}});
      }
  return {"touching lattice 12^3", {from(a), from(b)}};
}

Scene zero_size() {
  // Points (min == max) on a coarse grid: coincident points collide; +0/-0.
  std::mt19937 rng(4);
  std::uniform_int_distribution<int> cell(-5, 5);
  std::vector<Aabb> v;
  for (int i = 0; i < 1500; ++i) {
    const float x = float(cell(rng)), y = float(cell(rng)), z = float(cell(rng));
    v.push_back({{x, y, z}, {x, y, z}});
  }
  v.push_back({{-0.0f, -0.0f, -0.0f}, {-0.0f, -0.0f, -0.0f}});
  v.push_back({{0.0f, 0.0f, 0.0f}, {0.0f, 0.0f, 0.0f}});
  return {"zero-size points", {from(v)}};
}

Scene huge_coordinates() {
  // Centres in [-1e30, 1e30], sizes up to 1e29; plus boxes at +-FLT_MAX and
  // one spanning the whole float range.
  std::mt19937 rng(5);
  std::uniform_real_distribution<float> pos(-1e30f, 1e30f), size(0, 1e29f);
  std::vector<Aabb> v;
  for (int i = 0; i < 1500; ++i) {
    const float x = pos(rng), y = pos(rng), z = pos(rng);
    v.push_back({{x, y, z}, {x + size(rng), y + size(rng), z + size(rng)}});
  }
  v.push_back({{kMax, kMax, kMax}, {kMax, kMax, kMax}});
  v.push_back({{-kMax, -kMax, -kMax}, {-kMax, -kMax, -kMax}});
  v.push_back({{-kMax, -kMax, -kMax}, {kMax, kMax, kMax}});
  v.push_back({{1e30f, -kMax, 0}, {kMax, 1e30f, 1e30f}});
  return {"coordinates near +-1e30 and FLT_MAX", {from(v)}};
}

Scene denormals() {
  // Everything within a few thousand ulps of 0: denormal corners and sizes,
  // the smallest denormal, signed zeros.
  std::mt19937 rng(6);
  std::uniform_int_distribution<int> ulps(-400, 400), len(0, 150);
  std::vector<Aabb> v;
  for (int i = 0; i < 1500; ++i) {
    Aabb b{};
    for (int k = 0; k < 3; ++k) {
      b.min[k] = float(ulps(rng)) * kDenormMin;
      b.max[k] = b.min[k] + float(len(rng)) * kDenormMin;
    }
    v.push_back(b);
  }
  v.push_back({{-kDenormMin, -kDenormMin, -kDenormMin}, {kDenormMin, kDenormMin, kDenormMin}});
  v.push_back({{0.0f, 0.0f, 0.0f}, {kDenormMin, kDenormMin, kDenormMin}});
  v.push_back({{-0.0f, -0.0f, -0.0f}, {-0.0f, -0.0f, -0.0f}});
  v.push_back({{std::numeric_limits<float>::min(), 0, 0}, {std::numeric_limits<float>::min(), 0, 0}});
  return {"near 0 with denormals", {from(v)}};
}

Scene one_object() { return {"one object", {from({cube(0, 0, 0, 1)}), from({cube(1e6f, 0, 0, 1)})}}; }

Scene zero_objects() { return {"zero objects", {BoxArray{}, BoxArray{}}}; }

Scene overfull_cell() {
  // 1100 identical boxes (more than the area-efficient buffer's 1024 and any
  // cell limit) plus a chain of boxes next to them.
  std::vector<Aabb> v(1100, Aabb{{0, 0, 0}, {1, 1, 1}});
  for (int i = 0; i < 100; ++i) v.push_back(cube(1.0f + float(i), 0, 0, 1));
  return {"overfull cell (1100 identical + chain)", {from(v)}};
}

Scene teleport() {
  // Frame 0: uniform; frame 1: every object jumps 1e6 away, order shuffled;
  // frame 2: all collapse into one point; frame 3: uniform again.
  std::mt19937 rng(7);
  std::uniform_real_distribution<float> pos(0, 200), size(1, 8);
  std::vector<Aabb> a;
  for (int i = 0; i < 1500; ++i) a.push_back(cube(pos(rng), pos(rng), pos(rng), size(rng)));
  std::vector<Aabb> b = a;
  std::shuffle(b.begin(), b.end(), rng);
  for (Aabb& x : b)
    for (int k = 0; k < 3; ++k) {
      x.min[k] += 1e6f;
      x.max[k] += 1e6f;
    }
  std::vector<Aabb> c(1500, Aabb{{5, 5, 5}, {5, 5, 5}});
  std::vector<Aabb> d;
  for (int i = 0; i < 1500; ++i) d.push_back(cube(pos(rng), pos(rng), pos(rng), size(rng)));
  return {"every object teleports", {from(a), from(b), from(c), from(d)}};
}

// ---- Runner -----------------------------------------------------------------

struct Config {
  std::string engine;
  std::uint32_t cell_limit;  // 0: the engine's default
};

// ae-small / mo-small: the two microarchitectures with buffers of 24 and
// 32 objects, so that most cells of the scenes above overflow the buffer
// and the hybrid system has to tile them.
void register_small_engines() {
  static std::once_flag once;
  std::call_once(once, [] {
    hbp::register_cell_engine("ae-small", [] {
      hbp::hw::ModelConfig cfg;
      cfg.m = 4;
      cfg.depth = 24;
      return hbp::hw::make_area_efficient_engine(cfg);
    });
    hbp::register_cell_engine("mo-small", [] {
      hbp::hw::ModelConfig cfg;
      cfg.m = 4;
      cfg.depth = 8;
      return hbp::hw::make_many_object_engine(cfg);
    });
  });
}

const std::vector<Config>& configs() {
  static const std::vector<Config> c = {
      {"sw", 0}, {"sw", 2}, {"sw", 16}, {"sw-allpairs", 0}, {"sw-allpairs", 7},
      {"ae", 0}, {"ae", 64}, {"mo", 0},  {"ae-small", 24},  {"mo-small", 32},
  };
  return c;
}

struct Row {
  std::string scene;
  std::size_t n;
  std::vector<std::size_t> pairs;  // per frame
  std::string status;
};

std::vector<Row>& table() {
  static std::vector<Row> rows;
  return rows;
}

void run_scene(const Scene& scene) {
  register_small_engines();
  std::vector<std::vector<Pair>> want;
  for (const BoxArray& f : scene.frames) want.push_back(hbp::brute_force_pairs(f));
  std::size_t checked = 0;
  for (const Config& c : configs()) {
    HybridBroadPhase bp({.engine = c.engine, .cell_limit = c.cell_limit, .threads = 2});
    for (std::size_t f = 0; f < scene.frames.size(); ++f) {
      const std::vector<Pair>& got = bp.update(scene.frames[f]);
      const hbp::PairSetDiff diff = hbp::diff_pairs(want[f], got);
      ASSERT_TRUE(diff.empty()) << scene.name << ", engine " << c.engine << ", cell limit " << bp.cell_limit()
                                << ", frame " << f << ": " << diff.summary();
      ASSERT_EQ(got.size(), want[f].size()) << "duplicates: " << scene.name << ", engine " << c.engine;
      ASSERT_EQ(bp.stats().pairs, want[f].size());
      ++checked;
    }
  }
  Row row{scene.name, scene.frames.front().size(), {}, ""};
  for (const auto& w : want) row.pairs.push_back(w.size());
  row.status = "exact: " + std::to_string(checked) + " frames (" + std::to_string(configs().size()) +
               " engine configs)";
  table().push_back(row);
}

class TablePrinter : public ::testing::Environment {
 public:
  void TearDown() override {
    if (table().size() < 2) return;  // one test per process under ctest
    std::printf("\n| scene | n | pairs per frame | status |\n| --- | ---: | --- | --- |\n");
    for (const Row& r : table()) {
      std::string pairs;
      for (std::size_t i = 0; i < r.pairs.size(); ++i) pairs += (i ? ", " : "") + std::to_string(r.pairs[i]);
      std::printf("| %s | %zu | %s | %s |\n", r.scene.c_str(), r.n, pairs.c_str(), r.status.c_str());
    }
  }
};
const auto* const kPrinter = ::testing::AddGlobalTestEnvironment(new TablePrinter);

// ---- Tests ------------------------------------------------------------------

TEST(Adversarial, AllIdentical) {
  const Scene s = identical();
  run_scene(s);
  EXPECT_EQ(hbp::brute_force_pairs(s.frames[0]).size(), 600u * 599u / 2u);
}

TEST(Adversarial, NestedConcentric) {
  const Scene s = nested_concentric();
  run_scene(s);
  EXPECT_EQ(hbp::brute_force_pairs(s.frames[0]).size(), 500u * 499u / 2u);
}

TEST(Adversarial, NestedInOneHugeBox) {
  const Scene s = one_huge_box();
  run_scene(s);
  // The huge box (id 999 after the rotation) meets every other box.
  std::size_t with_huge = 0;
  for (const Pair& p : hbp::brute_force_pairs(s.frames[0])) with_huge += (p.a == 999 || p.b == 999);
  EXPECT_EQ(with_huge, 1999u);
}

TEST(Adversarial, SinglePlane) { run_scene(single_plane()); }

TEST(Adversarial, SingleLine) { run_scene(single_line()); }

TEST(Adversarial, TouchingLattice) {
  const Scene s = touching_lattice();
  run_scene(s);
  // Integer lattice: each cube meets its 26-neighbourhood; count the pairs
  // (cells differing by at most 1 per axis) as sum over axes combinations.
  // Per axis, the number of ordered index pairs (i, i') with |i - i'| <= 1 is
  // 12 + 2 * 11 = 34, so unordered distinct pairs = (34^3 - 12^3) / 2.
  EXPECT_EQ(hbp::brute_force_pairs(s.frames[0]).size(), (34u * 34u * 34u - 12u * 12u * 12u) / 2u);
}

TEST(Adversarial, ZeroSizePoints) { run_scene(zero_size()); }

TEST(Adversarial, HugeCoordinates) {
  const Scene s = huge_coordinates();
  run_scene(s);
  // The box spanning the whole float range meets every other box.
  const auto all = static_cast<std::uint32_t>(s.frames[0].size() - 2);
  std::size_t with_all = 0;
  for (const Pair& p : hbp::brute_force_pairs(s.frames[0])) with_all += (p.a == all || p.b == all);
  EXPECT_EQ(with_all, s.frames[0].size() - 1);
}

TEST(Adversarial, NearZeroWithDenormals) { run_scene(denormals()); }

TEST(Adversarial, OneObject) {
  const Scene s = one_object();
  run_scene(s);
  EXPECT_TRUE(hbp::brute_force_pairs(s.frames[0]).empty());
}

TEST(Adversarial, ZeroObjects) { run_scene(zero_objects()); }

TEST(Adversarial, MoreObjectsPerCellThanAnyCapacity) {
  const Scene s = overfull_cell();
  run_scene(s);
  // 1100 identical: 1100*1099/2; the first chain box touches all of them.
  EXPECT_EQ(hbp::brute_force_pairs(s.frames[0]).size(), 1100u * 1099u / 2u + 1100u + 99u);
}

TEST(Adversarial, EveryObjectTeleports) {
  const Scene s = teleport();
  run_scene(s);
  EXPECT_EQ(hbp::brute_force_pairs(s.frames[2]).size(), 1500u * 1499u / 2u);
}

TEST(Adversarial, SinkAndUnsortedOutputOnOverfullCells) {
  // The narrow-phase hook path (parallel pipeline) and cell-order output on
  // the tiled cells: same pair set, each pair once.
  register_small_engines();
  const Scene s = overfull_cell();
  const auto want = hbp::brute_force_pairs(s.frames[0]);
  for (const char* engine : {"sw", "ae", "mo-small"}) {
    HybridBroadPhase bp({.engine = engine, .cell_limit = 16, .threads = 2, .sorted = false});
    std::vector<Pair> seen;
    std::uint32_t last_cell = 0, calls = 0;
    bool in_order = true;
    bp.update(s.frames[0], [&](std::uint32_t cell, const Pair* p, std::size_t count) {
      in_order &= calls++ == 0 || cell > last_cell;
      last_cell = cell;
      seen.insert(seen.end(), p, p + count);
    });
    EXPECT_TRUE(in_order) << engine;
    EXPECT_EQ(calls, bp.stats().cells) << engine;
    std::vector<Pair> got = bp.pairs();
    EXPECT_EQ(hbp::canonicalize(got), 0u) << engine;
    EXPECT_EQ(got, want) << engine;
    EXPECT_EQ(hbp::canonicalize(seen), 0u) << engine;
    EXPECT_EQ(seen, want) << engine;
  }
}

TEST(Adversarial, CollisionPipelineSameContactsOnOneOrTwoThreads) {
  // The broad phase overlapped with the narrow phase on worker threads (the
  // TSan pass runs this): same candidates as the oracle, same contacts in
  // the same order whatever the thread count, frame after frame.
  hbp::ScenarioParams p;
  p.n = 3000;
  p.seed = 9;
  hbp::Scenario scene(p);
  hbp::CollisionPipeline one({.engine = "sw", .cell_limit = 64, .threads = 1});
  hbp::CollisionPipeline two({.engine = "sw", .cell_limit = 64, .threads = 2});
  two.reserve(p.n);  // memory only: the same contacts
  BoxArray boxes;
  for (int f = 0; f < 3; ++f) {
    scene.compute_boxes(boxes);
    const auto a = one.update(boxes, scene.shapes());
    const auto& b = two.update(boxes, scene.shapes());
    ASSERT_EQ(two.stats().candidates, hbp::brute_force_pairs(boxes).size()) << "frame " << f;
    ASSERT_FALSE(a.empty());
    ASSERT_EQ(a.size(), b.size()) << "frame " << f;
    for (std::size_t i = 0; i < a.size(); ++i) {
      ASSERT_EQ(a[i].a, b[i].a) << "frame " << f << " contact " << i;
      ASSERT_EQ(a[i].b, b[i].b) << "frame " << f << " contact " << i;
      ASSERT_EQ(a[i].depth, b[i].depth) << "frame " << f << " contact " << i;
    }
    scene.step();
  }
}

}  // namespace
