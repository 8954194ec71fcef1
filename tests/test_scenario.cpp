// SPDX-License-Identifier: MIT
// The paper's benchmark scenario (section 5) and the other scenario kinds:
// defaults, distributions, walls, determinism across runs and thread counts.
#include <gtest/gtest.h>
#include <tbb/global_control.h>

#include <algorithm>
#include <cmath>
#include <cstring>
#include <set>
#include <string>
#include <tuple>
#include <vector>

#include "hbp/brute_force.hpp"
#include "hbp/error.hpp"
#include "hbp/scenario.hpp"

namespace {

using hbp::BoxArray;
using hbp::Scenario;
using hbp::ScenarioKind;
using hbp::ScenarioParams;

const ScenarioKind kAllKinds[] = {ScenarioKind::Paper, ScenarioKind::Clustered, ScenarioKind::Flat, ScenarioKind::Huge,
                                  ScenarioKind::Degenerate};

bool bit_identical(const BoxArray& a, const BoxArray& b) {
  if (a.size() != b.size()) return false;
  for (int k = 0; k < 3; ++k) {
    if (std::memcmp(a.min(k), b.min(k), a.size() * sizeof(float)) != 0) return false;
    if (std::memcmp(a.max(k), b.max(k), a.size() * sizeof(float)) != 0) return false;
  }
  return true;
}

BoxArray boxes_after(const ScenarioParams& p, int steps) {
  Scenario s(p);
  for (int i = 0; i < steps; ++i) s.step();
  BoxArray b;
  s.compute_boxes(b);
  return b;
}

TEST(ScenarioParams, DefaultsAreThePapers) {
  const ScenarioParams p;
  EXPECT_EQ(p.kind, ScenarioKind::Paper);
  EXPECT_EQ(p.frames, 1000u);   // 1000 collision-detection cycles
  EXPECT_EQ(p.variants, 20u);   // 20 variants
  EXPECT_EQ(p.size_min, 25.0);  // sizes between 25 and 75 m
  EXPECT_EQ(p.size_max, 75.0);
  EXPECT_EQ(p.linear_speed, 25.0);  // (-25,-25,-25) .. (25,25,25) m/s
  EXPECT_EQ(p.angular_speed, 2.5);  // (-2.5,...) .. (2.5,...) rad/s
  EXPECT_EQ(p.volume_per_object, 50.0 * 50.0 * 50.0 * 5.0);
  EXPECT_DOUBLE_EQ(p.dt, 1.0 / 60.0);  // our choice, documented
}

TEST(ScenarioParams, WorldSideIsCubeRootOf50CubedTimes5n) {
  for (std::uint32_t n : {100u, 1000u, 16000u, 1024000u}) {
    ScenarioParams p;
    p.n = n;
    const double expected = std::cbrt(50.0 * 50.0 * 50.0 * 5.0 * n);
    EXPECT_NEAR(p.world_side(), expected, 1e-9 * expected) << n;
    if (n <= 16000) {  // do not build a million shapes for this
      const hbp::Aabb w = Scenario(p).world_bounds();
      EXPECT_EQ(w.min[0], 0.0f);
      EXPECT_FLOAT_EQ(w.max[2], static_cast<float>(expected));
    }
  }
  ScenarioParams p;
  p.n = 1000;
  EXPECT_NEAR(p.world_side(), 854.98797, 1e-4);  // 50 * cbrt(5000)
}

TEST(PaperScenario, SizesPositionsAndShapesAreUniform) {
  ScenarioParams p;
  p.n = 20000;
  p.seed = 3;
  const Scenario s(p);
  const double side = p.world_side();
  double size_sum = 0, pos_sum[3] = {0, 0, 0};
  int kinds[hbp::kShapeKindCount] = {};
  for (const auto& shape : s.shapes()) {
    for (int a = 0; a < 3; ++a) {
      ASSERT_GE(shape.size[a], 25.0);
      ASSERT_LT(shape.size[a], 75.0);
      ASSERT_GE(shape.position[a], 0.0);
      ASSERT_LE(shape.position[a], side);
      size_sum += shape.size[a];
      pos_sum[a] += shape.position[a];
    }
    const auto& q = shape.orientation;
    ASSERT_NEAR(q.w * q.w + q.x * q.x + q.y * q.y + q.z * q.z, 1.0, 1e-12);
    ++kinds[static_cast<int>(shape.kind)];
  }
  EXPECT_NEAR(size_sum / (3.0 * p.n), 50.0, 0.5);
  for (double sum : pos_sum) EXPECT_NEAR(sum / p.n, side / 2, 0.01 * side);
  for (int count : kinds) EXPECT_NEAR(count, p.n / 4.0, 0.04 * p.n);
}

TEST(PaperScenario, VelocitiesSpanThePapersRanges) {
  // Velocities are private; one step reveals them. Objects further than one
  // step from every wall move freely.
  ScenarioParams p;
  p.n = 20000;
  p.seed = 5;
  Scenario s(p);
  const auto before = s.shapes();
  s.step();
  const double side = p.world_side(), reach = p.linear_speed * p.dt;
  double abs_sum = 0, max_abs = 0, w2_sum = 0, max_w = 0;
  int free_axes = 0;
  for (std::size_t i = 0; i < before.size(); ++i) {
    for (int a = 0; a < 3; ++a) {
      const double x0 = before[i].position[a];
      if (x0 < reach || x0 > side - reach) continue;
      const double v = (s.shapes()[i].position[a] - x0) / p.dt;
      ASSERT_LE(std::fabs(v), 25.0 + 1e-9);
      abs_sum += std::fabs(v);
      max_abs = std::max(max_abs, std::fabs(v));
      ++free_axes;
    }
    // Rotation angle of this step from the relative rotation q1 * conj(q0).
    const auto q0 = before[i].orientation;
    const auto rel = hbp::multiply(s.shapes()[i].orientation, hbp::Quat{q0.w, -q0.x, -q0.y, -q0.z});
    const double angle = 2 * std::atan2(std::sqrt(rel.x * rel.x + rel.y * rel.y + rel.z * rel.z), std::fabs(rel.w));
    const double w = angle / p.dt;
    ASSERT_LE(w, std::sqrt(3.0) * 2.5 + 1e-9);
    w2_sum += w * w;
    max_w = std::max(max_w, w);
  }
  // Uniform in [-25, 25]: mean |v| = 12.5; uniform in [-2.5, 2.5] per axis:
  // mean |w|^2 = 3 * 2.5^2 / 3 = 6.25.
  EXPECT_NEAR(abs_sum / free_axes, 12.5, 0.2);
  EXPECT_GT(max_abs, 24.9);
  EXPECT_NEAR(w2_sum / p.n, 6.25, 0.1);
  EXPECT_GT(max_w, 3.5);
}

TEST(PaperScenario, CentresStayInsideTheCubeAndReflect) {
  ScenarioParams p;
  p.n = 500;
  p.dt = 0.5;  // 12.5 m per step at full speed: many wall hits
  Scenario s(p);
  const double side = p.world_side();
  std::vector<int> reflections(p.n, 0);
  auto previous = s.shapes();
  std::vector<hbp::Vec3> previous_step(p.n);
  for (int step = 0; step < 300; ++step) {
    s.step();
    for (std::uint32_t i = 0; i < p.n; ++i) {
      const auto& now = s.shapes()[i].position;
      const hbp::Vec3 delta{now.x - previous[i].position.x, now.y - previous[i].position.y,
                            now.z - previous[i].position.z};
      for (int a = 0; a < 3; ++a) {
        ASSERT_GE(now[a], 0.0) << "object " << i << " step " << step;
        ASSERT_LE(now[a], side) << "object " << i << " step " << step;
        if (step > 0 && delta[a] * previous_step[i][a] < 0) ++reflections[i];
      }
      previous_step[i] = delta;
    }
    previous = s.shapes();
  }
  // Each object travels far more than the side: nearly all must have bounced.
  const auto bounced = std::count_if(reflections.begin(), reflections.end(), [](int r) { return r > 0; });
  EXPECT_GT(bounced, static_cast<long>(0.95 * p.n));
}

TEST(Determinism, SameParametersGiveBitIdenticalBoxes) {
  for (auto kind : kAllKinds) {
    ScenarioParams p;
    p.kind = kind;
    p.n = 3000;
    p.seed = 11;
    EXPECT_TRUE(bit_identical(boxes_after(p, 7), boxes_after(p, 7))) << hbp::scenario_kind_name(kind);
    ScenarioParams q = p;
    q.seed = 12;
    EXPECT_FALSE(bit_identical(boxes_after(p, 7), boxes_after(q, 7))) << hbp::scenario_kind_name(kind);
  }
}

TEST(Determinism, ThreadCountDoesNotChangeABit) {
  ScenarioParams p;
  p.n = 40000;  // several 4096-object blocks per parallel loop
  p.seed = 2;
  std::vector<BoxArray> results;
  for (std::size_t threads : {1, 2, 3, 8}) {
    tbb::global_control limit(tbb::global_control::max_allowed_parallelism, threads);
    results.push_back(boxes_after(p, 5));
  }
  for (std::size_t i = 1; i < results.size(); ++i) EXPECT_TRUE(bit_identical(results[0], results[i])) << i;
}

TEST(ScenarioKinds, EveryKindGeneratesValidBoxesEveryFrame) {
  for (auto kind : kAllKinds) {
    ScenarioParams p;
    p.kind = kind;
    p.n = 2000;
    Scenario s(p);
    BoxArray b;
    for (int frame = 0; frame < 20; ++frame) {
      s.compute_boxes(b);
      ASSERT_EQ(b.size(), p.n);
      const std::string what = std::string(hbp::scenario_kind_name(kind)) + " frame " + std::to_string(frame);
      EXPECT_NO_THROW(b.validate(what.c_str())) << what;
      s.step();
    }
  }
}

TEST(ScenarioKinds, FlatKeepsEveryCentreOnThePlane) {
  ScenarioParams p;
  p.kind = ScenarioKind::Flat;
  p.n = 2000;
  Scenario s(p);
  for (int step = 0; step < 30; ++step) s.step();
  const double plane = 0.5 * p.world_side();
  for (const auto& shape : s.shapes()) ASSERT_EQ(shape.position.z, plane);
}

TEST(ScenarioKinds, HugeHasAFewObjectsSpanningMostOfTheWorld) {
  ScenarioParams p;
  p.kind = ScenarioKind::Huge;
  p.n = 2000;
  const Scenario s(p);
  const double side = p.world_side();
  for (std::uint32_t i = 0; i < p.n; ++i) {
    const auto& shape = s.shapes()[i];
    for (int a = 0; a < 3; ++a) {
      if (i < p.huge_objects) {
        EXPECT_EQ(shape.kind, hbp::ShapeKind::Cuboid);
        EXPECT_GE(shape.size[a], 0.5 * side);
        EXPECT_LE(shape.size[a], 0.9 * side);
      } else {
        ASSERT_LT(shape.size[a], p.size_max);
      }
    }
  }
  // A huge object overlaps a large share of the scene.
  BoxArray b;
  s.compute_boxes(b);
  const auto pairs = hbp::brute_force_pairs(b);
  const auto with_object_0 = std::count_if(pairs.begin(), pairs.end(), [](const hbp::Pair& q) { return q.a == 0; });
  EXPECT_GT(with_object_0, 2000 / 20);
}

TEST(ScenarioKinds, ClusteredOccupiesFewCellsOfTheWorld) {
  auto occupied_cells = [](ScenarioKind kind) {
    ScenarioParams p;
    p.kind = kind;
    p.n = 4000;
    const Scenario s(p);
    const double side = p.world_side();
    std::set<int> cells;
    for (const auto& shape : s.shapes()) {
      int c[3];
      for (int a = 0; a < 3; ++a) c[a] = std::min(9, static_cast<int>(10 * shape.position[a] / side));
      cells.insert(c[0] + 10 * c[1] + 100 * c[2]);
    }
    return cells.size();
  };
  EXPECT_GT(occupied_cells(ScenarioKind::Paper), 950u);  // 4000 uniform points in 1000 cells
  EXPECT_LT(occupied_cells(ScenarioKind::Clustered), 200u);
}

TEST(ScenarioKinds, DegenerateHasPointsContactsAndCopiesOnExactCoordinates) {
  ScenarioParams p;
  p.kind = ScenarioKind::Degenerate;
  p.n = 3000;
  Scenario s(p);
  for (int step = 0; step < 2; ++step) {
    BoxArray b;
    s.compute_boxes(b);
    std::size_t points = 0;
    std::vector<std::vector<float>> rows;
    for (std::size_t i = 0; i < b.size(); ++i) {
      const auto box = b.get(i);
      bool point = true;
      for (int a = 0; a < 3; ++a) {
        // Quarter-metre lattice: every coordinate exact in float.
        ASSERT_EQ(box.min[a] * 4, std::round(box.min[a] * 4)) << i;
        ASSERT_EQ(box.max[a] * 4, std::round(box.max[a] * 4)) << i;
        point = point && box.min[a] == box.max[a];
      }
      points += point;
      rows.push_back({box.min[0], box.min[1], box.min[2], box.max[0], box.max[1], box.max[2]});
    }
    EXPECT_EQ(points, p.n / 3);
    std::sort(rows.begin(), rows.end());
    EXPECT_NE(std::adjacent_find(rows.begin(), rows.end()), rows.end()) << "no identical boxes";
    // Exact contacts: overlapping pairs whose intersection has zero volume.
    std::size_t contacts = 0;
    for (const auto& pair : hbp::brute_force_pairs(b)) {
      const auto x = b.get(pair.a), y = b.get(pair.b);
      bool flat = false;
      for (int a = 0; a < 3; ++a) flat = flat || std::min(x.max[a], y.max[a]) == std::max(x.min[a], y.min[a]);
      contacts += flat;
    }
    EXPECT_GT(contacts, 100u);
    s.step();
  }
}

TEST(ScenarioKinds, NamesRoundTrip) {
  for (auto kind : kAllKinds) EXPECT_EQ(hbp::parse_scenario_kind(hbp::scenario_kind_name(kind)), kind);
  EXPECT_THROW(hbp::parse_scenario_kind("sparse"), hbp::InvalidInput);
}

TEST(ScenarioParams, InvalidParametersAreRejected) {
  auto rejects = [](auto&& change) {
    ScenarioParams p;
    p.n = 10;
    change(p);
    EXPECT_THROW(Scenario{p}, hbp::InvalidInput);
  };
  rejects([](ScenarioParams& p) { p.dt = 0; });
  rejects([](ScenarioParams& p) { p.dt = NAN; });
  rejects([](ScenarioParams& p) { p.size_min = 80; });
  rejects([](ScenarioParams& p) { p.size_min = -1; });
  rejects([](ScenarioParams& p) { p.linear_speed = -1; });
  rejects([](ScenarioParams& p) { p.angular_speed = INFINITY; });
  rejects([](ScenarioParams& p) { p.volume_per_object = 0; });
  rejects([](ScenarioParams& p) {
    p.kind = ScenarioKind::Clustered;
    p.clusters = 0;
  });
  rejects([](ScenarioParams& p) { p.cluster_sigma = -1; });
  rejects([](ScenarioParams& p) { p.cluster_sigma = NAN; });
  rejects([](ScenarioParams& p) { p.cluster_sigma = 0; });
  rejects([](ScenarioParams& p) {
    p.kind = ScenarioKind::Huge;
    p.huge_objects = 11;
  });
  rejects([](ScenarioParams& p) { p.volume_per_object = 1e300; });  // world past float range
  rejects([](ScenarioParams& p) { p.size_max = 2e30; });
}

// Sizes past kMaxScenarioObjects are refused before anything is allocated,
// naming n and the limit (they used to end in std::bad_alloc).
TEST(ScenarioParams, ObjectCountLimitIsCheckedUpFront) {
  for (const std::uint32_t n : {hbp::kMaxScenarioObjects + 1, 2147483647u, 4000000000u}) {
    ScenarioParams p;
    p.n = n;
    try {
      Scenario s(p);
      ADD_FAILURE() << "n = " << n << " accepted";
    } catch (const hbp::InvalidInput& e) {
      const std::string msg = e.what();
      EXPECT_NE(msg.find(std::to_string(n)), std::string::npos) << msg;
      EXPECT_NE(msg.find(std::to_string(hbp::kMaxScenarioObjects)), std::string::npos) << msg;
    }
  }
  // Huge with exactly n huge objects, and a clustered scene's sigma, are fine.
  ScenarioParams p;
  p.kind = ScenarioKind::Huge;
  p.n = 4;
  p.huge_objects = 4;
  EXPECT_EQ(Scenario(p).size(), 4u);
}

TEST(ScenarioParams, OverridesTakeEffect) {
  ScenarioParams p;
  p.n = 1000;
  p.size_min = 1;
  p.size_max = 2;
  p.volume_per_object = 1000;
  const Scenario s(p);
  EXPECT_NEAR(p.world_side(), 100.0, 1e-9);
  for (const auto& shape : s.shapes())
    for (int a = 0; a < 3; ++a) {
      ASSERT_GE(shape.size[a], 1.0);
      ASSERT_LT(shape.size[a], 2.0);
      ASSERT_LE(shape.position[a], 100.0);
    }
}

}  // namespace
