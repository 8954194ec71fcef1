// SPDX-License-Identifier: MIT
// Ray traversal of the two-level hierarchy against brute force: for random
// rays, the closest hit (object and distance, bit for bit) equals the one
// found by testing every object; shadow (any-hit) queries agree too. 100,000
// rays on the paper scene (n = 400, as in Fig. 3), and more on other scenes,
// cell limits and frames (after refits, edits and rebuilds).
#include <gtest/gtest.h>
#include <tbb/parallel_for.h>

#include <atomic>
#include <cmath>
#include <random>
#include <vector>

#include "hbp/raytrace/traversal.hpp"
#include "hbp/scenario.hpp"
#include "hierarchy/cell_bvh.hpp"
#include "scenario_hierarchy.hpp"

namespace hbp {
namespace {

// Half the rays start anywhere in (and around) the world, in a random
// direction; half come from outside towards a random object's centre, so most
// of them hit something. Every fourth ray has a finite tmax.
std::vector<Ray> random_rays(const Scenario& scenario, std::uint32_t count, std::uint64_t seed) {
  std::mt19937_64 rng(seed);
  const double side = scenario.params().world_side();
  std::uniform_real_distribution<double> u(-0.2 * side, 1.2 * side), g(-1, 1), unit(0, 1);
  auto direction = [&](double d[3]) {
    double len;
    do {
      for (int k = 0; k < 3; ++k) d[k] = g(rng);
      len = std::sqrt(d[0] * d[0] + d[1] * d[1] + d[2] * d[2]);
    } while (len < 1e-3 || len > 1);
    for (int k = 0; k < 3; ++k) d[k] /= len;
  };
  std::vector<Ray> rays(count);
  for (std::uint32_t i = 0; i < count; ++i) {
    Ray& r = rays[i];
    if (i % 2 == 0) {
      for (int k = 0; k < 3; ++k) r.origin[k] = u(rng);
      direction(r.dir);
    } else {
      double d[3];
      direction(d);
      const Shape& target = scenario.shapes()[rng() % scenario.size()];
      const double c[3] = {target.position.x + 10 * g(rng), target.position.y + 10 * g(rng),
                           target.position.z + 10 * g(rng)};
      for (int k = 0; k < 3; ++k) {
        r.origin[k] = c[k] + 2 * side * d[k];
        r.dir[k] = -d[k];
      }
    }
    r.tmin = 0;
    r.tmax = i % 4 == 3 ? unit(rng) * 2 * side : 1e300;
  }
  return rays;
}

struct Agreement {
  std::uint64_t rays = 0, hits = 0, closest_mismatch = 0, any_mismatch = 0, bvh_mismatch = 0;
};

// Compares traversal with brute force for every ray (in parallel).
Agreement compare(const TwoLevelHierarchy& h, std::span<const ShapeGeometry> geometry, const std::vector<Ray>& rays,
                  std::span<const BvhNode> full_bvh = {}) {
  std::atomic<std::uint64_t> hits{0}, closest{0}, any{0}, bvh{0};
  tbb::parallel_for(tbb::blocked_range<std::size_t>(0, rays.size(), 256), [&](const auto& r) {
    for (std::size_t i = r.begin(); i != r.end(); ++i) {
      const Ray& ray = rays[i];
      const RayHit want = brute_force_closest_hit(geometry, ray);
      const RayHit got = closest_hit(h, geometry, ray);
      if (want.hit()) ++hits;
      if (got.object != want.object || (want.hit() && (got.t != want.t || got.part != want.part))) {
        if (closest.fetch_add(1) < 5)
          ADD_FAILURE() << "ray " << i << ": traversal object " << got.object << " t " << got.t
                        << ", brute force object " << want.object << " t " << want.t;
      }
      if (any_hit(h, geometry, ray) != want.hit()) ++any;
      if (!full_bvh.empty()) {
        const RayHit b = closest_hit(full_bvh, geometry, ray);
        if (b.object != want.object || (want.hit() && b.t != want.t)) ++bvh;
      }
    }
  });
  return {rays.size(), hits.load(), closest.load(), any.load(), bvh.load()};
}

struct Case {
  ScenarioKind kind;
  std::uint32_t n;
  std::uint32_t cell_limit;
  std::uint32_t frames;  // frames simulated before the rays are cast
  std::uint32_t rays;
};

Agreement run_case(const Case& c) {
  test::ScenarioHierarchy w({.kind = c.kind, .n = c.n, .seed = 7}, {.cell_limit = c.cell_limit});
  for (std::uint32_t f = 0; f <= c.frames; ++f) w.frame(f);
  std::vector<ShapeGeometry> geometry;
  prepare_shapes(w.scenario.shapes(), geometry);
  std::vector<BvhNode> full;
  bvh::Scratch scratch;
  bvh::build(w.boxes, full, scratch);
  const Agreement a = compare(w.h, geometry, random_rays(w.scenario, c.rays, c.n + c.frames), full);
  EXPECT_EQ(a.closest_mismatch, 0u);
  EXPECT_EQ(a.any_mismatch, 0u);
  EXPECT_EQ(a.bvh_mismatch, 0u);
  return a;
}

TEST(RaytraceTraversal, PaperScene400HundredThousandRays) {
  // Cell limit 32 gives the 400 objects a real k-d tree (about 20 cells).
  const Agreement a = run_case({ScenarioKind::Paper, 400, 32, 60, 100000});
  EXPECT_EQ(a.rays, 100000u);
  EXPECT_GT(a.hits, 40000u);  // the aimed half mostly hits
}

TEST(RaytraceTraversal, PaperSceneDefaultCellLimitSingleCell) {
  const Agreement a = run_case({ScenarioKind::Paper, 400, 1024, 0, 10000});
  EXPECT_GT(a.hits, 4000u);
}

TEST(RaytraceTraversal, PaperSceneManyCellsAfterMaintenance) {
  const Agreement a = run_case({ScenarioKind::Paper, 4000, 64, 30, 12000});
  EXPECT_GT(a.hits, 5000u);
}

TEST(RaytraceTraversal, ClusteredScene) {
  const Agreement a = run_case({ScenarioKind::Clustered, 2000, 48, 10, 10000});
  EXPECT_GT(a.hits, 2500u);
}

TEST(RaytraceTraversal, HugeObjectsSpanningCells) {
  const Agreement a = run_case({ScenarioKind::Huge, 1000, 40, 5, 8000});
  EXPECT_GT(a.hits, 4000u);
}

TEST(RaytraceTraversal, FlatScene) {
  const Agreement a = run_case({ScenarioKind::Flat, 1000, 40, 5, 8000});
  EXPECT_GT(a.hits, 2000u);
}

TEST(RaytraceTraversal, DegenerateScene) {
  // Axis-aligned unit cubes with touching faces, zero-size boxes, stacks.
  const Agreement a = run_case({ScenarioKind::Degenerate, 600, 16, 3, 8000});
  EXPECT_GT(a.hits, 1000u);
}

TEST(RaytraceTraversal, AxisParallelRaysThroughSplitPlanes) {
  // Rays along the axes, starting exactly on the partition's split planes.
  ScenarioParams sp;
  sp.n = 1500;
  Scenario scenario(sp);
  TwoLevelHierarchy h({.cell_limit = 32});
  BoxArray boxes;
  scenario.compute_boxes(boxes);
  h.update(boxes);
  std::vector<ShapeGeometry> geometry;
  prepare_shapes(scenario.shapes(), geometry);
  std::vector<Ray> rays;
  std::mt19937 rng(5);
  const double side = sp.world_side();
  std::uniform_real_distribution<double> u(0, side);
  for (const KdNode& n : h.kd_nodes()) {
    if (n.axis < 0) continue;
    for (int dir_axis = 0; dir_axis < 3; ++dir_axis) {
      for (int sign : {-1, 1}) {
        Ray r;
        for (int k = 0; k < 3; ++k) {
          r.origin[k] = u(rng);
          r.dir[k] = 0;
        }
        r.origin[n.axis] = n.split;
        r.origin[dir_axis] = sign > 0 ? -0.1 * side : 1.1 * side;
        if (dir_axis == n.axis) r.origin[(n.axis + 1) % 3] = u(rng);
        r.dir[dir_axis] = sign;
        rays.push_back(r);
      }
    }
  }
  ASSERT_GT(rays.size(), 100u);
  const Agreement a = compare(h, geometry, rays);
  EXPECT_EQ(a.closest_mismatch, 0u);
  EXPECT_EQ(a.any_mismatch, 0u);
  EXPECT_GT(a.hits, rays.size() / 4);
}

}  // namespace
}  // namespace hbp
