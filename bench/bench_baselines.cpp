// SPDX-License-Identifier: MIT
// Google Benchmark of each baseline's per-frame update on the paper's scene
// (proxies created once, outside the timing; scene stepping paused). For the
// full comparison with our engines use `hbp bench paper`.
#include <benchmark/benchmark.h>

#include <string>

#include "hbp/baselines/baseline.hpp"
#include "hbp/scenario.hpp"

namespace {

void run(benchmark::State& state, const std::string& name) {
  hbp::ScenarioParams p;
  p.n = static_cast<std::uint32_t>(state.range(0));
  hbp::Scenario scenario(p);
  hbp::BoxArray boxes;
  scenario.compute_boxes(boxes);
  auto b = hbp::baselines::make_baseline(name);
  b->setup(boxes);
  for (auto _ : state) {
    state.PauseTiming();
    scenario.step();
    scenario.compute_boxes(boxes);
    state.ResumeTiming();
    b->update(boxes);
  }
  state.counters["raw_pairs"] = static_cast<double>(b->raw_pairs());
  state.counters["exact_pairs"] = static_cast<double>(b->exact_pairs().size());
  state.SetItemsProcessed(state.iterations() * static_cast<std::int64_t>(p.n));
}

void BM_BulletDbvt(benchmark::State& s) { run(s, "bullet-dbvt"); }
void BM_BulletDbvtDeferred(benchmark::State& s) { run(s, "bullet-dbvt-deferred"); }
void BM_BulletAxisSweep(benchmark::State& s) { run(s, "bullet-axis-sweep"); }
void BM_Cgal(benchmark::State& s) { run(s, "cgal"); }
void BM_BruteForce(benchmark::State& s) { run(s, "brute"); }
void BM_FclDynamicAabbTree(benchmark::State& s) { run(s, "fcl-dynamic-aabb-tree"); }
void BM_FclSap(benchmark::State& s) { run(s, "fcl-sap"); }
void BM_FclIntervalTree(benchmark::State& s) { run(s, "fcl-interval-tree"); }
void BM_FclSpatialHash(benchmark::State& s) { run(s, "fcl-spatial-hash"); }
void BM_OdeHash(benchmark::State& s) { run(s, "ode-hash"); }
void BM_OdeSap(benchmark::State& s) { run(s, "ode-sap"); }
void BM_OdeQuadTree(benchmark::State& s) { run(s, "ode-quadtree"); }

BENCHMARK(BM_BulletDbvt)->Arg(1000)->Arg(16000)->Arg(128000)->Unit(benchmark::kMillisecond);
BENCHMARK(BM_BulletDbvtDeferred)->Arg(1000)->Arg(16000)->Arg(128000)->Unit(benchmark::kMillisecond);
// Setup is quadratic (createProxy): kept to sizes that set up in seconds.
BENCHMARK(BM_BulletAxisSweep)->Arg(1000)->Arg(16000)->Unit(benchmark::kMillisecond);
BENCHMARK(BM_Cgal)->Arg(1000)->Arg(16000)->Arg(128000)->Unit(benchmark::kMillisecond);
BENCHMARK(BM_BruteForce)->Arg(1000)->Arg(4000)->Unit(benchmark::kMillisecond);
BENCHMARK(BM_FclDynamicAabbTree)->Arg(1000)->Arg(16000)->Unit(benchmark::kMillisecond);
BENCHMARK(BM_FclSap)->Arg(1000)->Arg(16000)->Unit(benchmark::kMillisecond);
BENCHMARK(BM_FclIntervalTree)->Arg(1000)->Arg(16000)->Unit(benchmark::kMillisecond);
BENCHMARK(BM_FclSpatialHash)->Arg(1000)->Arg(16000)->Unit(benchmark::kMillisecond);
BENCHMARK(BM_OdeHash)->Arg(1000)->Arg(16000)->Unit(benchmark::kMillisecond);
BENCHMARK(BM_OdeSap)->Arg(1000)->Arg(16000)->Unit(benchmark::kMillisecond);
BENCHMARK(BM_OdeQuadTree)->Arg(1000)->Arg(16000)->Unit(benchmark::kMillisecond);

}  // namespace
