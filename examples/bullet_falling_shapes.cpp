// SPDX-License-Identifier: MIT
// A Bullet world of spheres, boxes, cylinders and cones falling into a box
// container, with hbp::bullet::BroadphaseAdapter as its broad phase (the one
// line that differs from a stock Bullet program is marked below).
//
//   bullet_falling_shapes                     # 5,000 bodies, 600 steps, ours
//   bullet_falling_shapes --dbvt              # the same with btDbvtBroadphase
//   bullet_falling_shapes --compare           # both side by side, pairs checked
//
// Prints one line per step: contacts (manifolds with points, points), pairs
// the broad phase handed to the narrow phase, and timings.
#include <CLI/CLI.hpp>
#include <chrono>
#include <cstdio>
#include <memory>

#include "hbp/bullet/broadphase_adapter.hpp"
#include "integrations/world/falling_shapes_world.hpp"
#include "integrations/world/side_by_side.hpp"

namespace {

using hbp::bullet::world::FallingShapesConfig;
using hbp::bullet::world::FallingShapesWorld;

int run_one(const FallingShapesConfig& config, std::uint32_t steps, bool dbvt, const hbp::BroadPhaseOptions& options,
            std::uint32_t every) {
  std::unique_ptr<btBroadphaseInterface> broadphase;
  if (dbvt) {
    broadphase = std::make_unique<btDbvtBroadphase>();
  } else {
    broadphase = std::make_unique<hbp::bullet::BroadphaseAdapter>(options);  // <- the one line
  }
  FallingShapesWorld world(config, std::move(broadphase));
  world.dispatcher().set_recording(true);
  std::printf("%s, %zu bodies (%u falling), %u steps of 1/60 s\n",
              dbvt ? "btDbvtBroadphase" : "hbp::bullet::BroadphaseAdapter", world.body_count(), config.bodies, steps);
  double total_ms = 0, broadphase_ms = 0;
  for (std::uint32_t s = 1; s <= steps; ++s) {
    const auto t = std::chrono::steady_clock::now();
    world.step();
    const double ms = std::chrono::duration<double, std::milli>(std::chrono::steady_clock::now() - t).count();
    total_ms += ms;
    const auto& timing = world.timing();
    broadphase_ms += timing.update_aabbs_ms + timing.pairs_ms;
    if (s % every == 0 || s == steps) {
      const auto contacts = world.contacts();
      const auto& handed = world.dispatcher().last();
      std::printf("step %4u: %6llu contacts in %5llu manifolds; pairs handed %6zu (exact %6zu); "
                  "step %7.2f ms, broad phase %6.2f ms\n",
                  s, static_cast<unsigned long long>(contacts.points),
                  static_cast<unsigned long long>(contacts.manifolds), handed.raw, handed.exact.size(), ms,
                  timing.update_aabbs_ms + timing.pairs_ms);
    }
  }
  std::printf("mean step %.2f ms, broad phase (updateAabbs + computeOverlappingPairs) %.2f ms\n", total_ms / steps,
              broadphase_ms / steps);
  world.broadphase().printStats();
  return 0;
}

int run_compare(const FallingShapesConfig& config, std::uint32_t steps, const hbp::BroadPhaseOptions& options,
                std::uint32_t every) {
  std::printf("side by side: hbp::bullet::BroadphaseAdapter and btDbvtBroadphase, %u falling bodies, %u steps\n",
              config.bodies, steps);
  const auto summary = hbp::bullet::world::run_side_by_side(
      config, steps, options, [&](const hbp::bullet::world::StepComparison& c) {
        const bool ok = c.same_aabbs && c.same_pairs && c.hybrid_raw == c.hybrid_exact;
        if (c.step % every == 0 || c.step == steps || !ok)
          std::printf("step %4u: %s; exact pairs %6zu (hybrid cache %6zu, dbvt cache %6zu); contacts %6llu / %6llu; "
                      "step %7.2f / %7.2f ms%s%s\n",
                      c.step, ok ? "identical" : "DIFFERENT", c.hybrid_exact, c.hybrid_raw, c.dbvt_raw,
                      static_cast<unsigned long long>(c.hybrid_contacts.points),
                      static_cast<unsigned long long>(c.dbvt_contacts.points), c.hybrid_step_ms, c.dbvt_step_ms,
                      c.same_aabbs ? "" : " (AABBs differ)", c.difference.empty() ? "" : (" " + c.difference).c_str());
      });
  std::printf("%u of %u steps identical (exact pairs handed to the narrow phase), %llu pairs in all, at most %zu "
              "in a step; mean step %.2f ms (hybrid world) / %.2f ms (dbvt world)\n",
              summary.identical_steps, summary.steps, static_cast<unsigned long long>(summary.total_pairs),
              summary.max_pairs, summary.hybrid_step_ms / summary.steps, summary.dbvt_step_ms / summary.steps);
  return summary.identical_steps == summary.steps ? 0 : 1;
}

}  // namespace

int main(int argc, char** argv) {
  CLI::App app{"Falling shapes in a Bullet world with the hybrid broad phase"};
  FallingShapesConfig config;
  std::uint32_t steps = 600, every = 1;
  bool dbvt = false, compare = false;
  hbp::BroadPhaseOptions options;
  app.add_option("--bodies", config.bodies, "falling bodies")->capture_default_str();
  app.add_option("--steps", steps, "steps of 1/60 s")->capture_default_str()->check(CLI::PositiveNumber);
  app.add_option("--seed", config.seed, "scene seed")->capture_default_str();
  app.add_option("--every", every, "print every k-th step")->capture_default_str()->check(CLI::PositiveNumber);
  app.add_option("--threads", options.threads, "hybrid broad phase threads (0: all cores)")->capture_default_str();
  app.add_option("--engine", options.engine, "hybrid cell engine")->capture_default_str();
  app.add_flag("--dbvt", dbvt, "use btDbvtBroadphase instead");
  app.add_flag("--compare", compare, "run both broad phases side by side and compare their pairs every step");
  CLI11_PARSE(app, argc, argv);
  try {
    return compare ? run_compare(config, steps, options, every) : run_one(config, steps, dbvt, options, every);
  } catch (const std::exception& e) {
    std::fprintf(stderr, "bullet_falling_shapes: %s\n", e.what());
    return 2;
  }
}
