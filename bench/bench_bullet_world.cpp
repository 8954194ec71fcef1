// SPDX-License-Identifier: MIT
// Step time of the example Bullet world (spheres, boxes, cylinders, cones
// falling into a container) with each broad phase: hbp::bullet::BroadphaseAdapter
// (1 and 2 threads) and btDbvtBroadphase (Bullet's default). One iteration is
// a whole run from the same start (the world evolves, so steps are not
// interchangeable); world construction is not timed.
//
// Counters, per step:
//   ms, cpu_ms          the whole stepSimulation: wall, CPU time of all threads
//   broadphase_ms,      updateAabbs + computeOverlappingPairs (where both broad
//   broadphase_cpu_ms   phases do their work): wall, CPU time
//   pairs, exact_pairs  pairs handed to the narrow phase: raw, exact-filtered
//
//   bench_bullet_world --benchmark_filter='bodies:5000'   # the documented run
#include <benchmark/benchmark.h>

#include <time.h>

#include <chrono>
#include <memory>

#include "hbp/bullet/broadphase_adapter.hpp"
#include "integrations/world/falling_shapes_world.hpp"
#include "support/clock.hpp"

namespace {

using hbp::ms_since;
using hbp::SteadyClock;

// CPU time of the whole process (every thread), ms: on a shared machine wall
// time measures the neighbours too.
double process_cpu_ms() {
  timespec ts;
  clock_gettime(CLOCK_PROCESS_CPUTIME_ID, &ts);
  return static_cast<double>(ts.tv_sec) * 1e3 + static_cast<double>(ts.tv_nsec) * 1e-6;
}

using hbp::bullet::world::FallingShapesConfig;
using hbp::bullet::world::FallingShapesWorld;

enum Kind { kHybrid1 = 0, kHybrid2 = 1, kDbvt = 2 };

std::unique_ptr<btBroadphaseInterface> make_broadphase(Kind kind) {
  if (kind == kDbvt) return std::make_unique<btDbvtBroadphase>();
  return std::make_unique<hbp::bullet::BroadphaseAdapter>(
      hbp::BroadPhaseOptions{.engine = "sw", .threads = kind == kHybrid1 ? 1u : 2u});
}

void BM_BulletWorld(benchmark::State& state) {
  const auto kind = static_cast<Kind>(state.range(0));
  FallingShapesConfig config;
  config.bodies = static_cast<std::uint32_t>(state.range(1));
  const auto steps = static_cast<std::uint32_t>(state.range(2));
  double step_ms = 0, cpu_ms = 0, broadphase_ms = 0, broadphase_cpu_ms = 0, pairs = 0, exact = 0;
  for (auto _ : state) {
    state.PauseTiming();
    auto world = std::make_unique<FallingShapesWorld>(config, make_broadphase(kind));
    world->dispatcher().set_recording(true);
    state.ResumeTiming();
    for (std::uint32_t s = 0; s < steps; ++s) {
      const auto t = SteadyClock::now();
      const double c = process_cpu_ms();
      world->step();
      cpu_ms += process_cpu_ms() - c;
      step_ms += ms_since(t);
      broadphase_ms += world->timing().update_aabbs_ms + world->timing().pairs_ms;
      broadphase_cpu_ms += world->timing().update_aabbs_cpu_ms + world->timing().pairs_cpu_ms;
      pairs += static_cast<double>(world->dispatcher().last().raw);
      exact += static_cast<double>(world->dispatcher().last().exact.size());
    }
    state.PauseTiming();
    world.reset();
    state.ResumeTiming();
  }
  const double n = static_cast<double>(steps) * static_cast<double>(state.iterations());
  state.counters["ms"] = step_ms / n;
  state.counters["cpu_ms"] = cpu_ms / n;
  state.counters["broadphase_ms"] = broadphase_ms / n;
  state.counters["broadphase_cpu_ms"] = broadphase_cpu_ms / n;
  state.counters["pairs"] = pairs / n;
  state.counters["exact_pairs"] = exact / n;
  state.SetLabel(kind == kDbvt ? "btDbvtBroadphase" : kind == kHybrid1 ? "hybrid 1 thread" : "hybrid 2 threads");
}

// Arguments: broad phase (0 hybrid 1 thread, 1 hybrid 2 threads, 2 DBVT),
// falling bodies, steps.
BENCHMARK(BM_BulletWorld)
    ->ArgNames({"bp", "bodies", "steps"})
    ->ArgsProduct({{kHybrid1, kHybrid2, kDbvt}, {1000}, {300}})
    ->ArgsProduct({{kHybrid1, kHybrid2, kDbvt}, {5000}, {600}})
    ->Iterations(1)
    ->Unit(benchmark::kMillisecond);

}  // namespace
