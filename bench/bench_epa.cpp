// SPDX-License-Identifier: MIT
// EPA alone on the paper scene's colliding curved pairs (the pairs that reach
// EPA in `hbp bench narrow`: no closed form, GJK says intersecting), one
// thread. Frame 3 of the scene (seed 0); frame 2's contact normals are the
// warm directions. Reports CPU time per pair and EPA iterations per pair.
//
//   bench_epa --benchmark_filter=Epa --benchmark_min_time=1
//   valgrind --tool=callgrind --toggle-collect='*run_epa*' bench_epa --benchmark_filter=EpaCold --benchmark_min_time=0.01
//   valgrind --tool=callgrind --toggle-collect='*run_warm*' bench_epa --benchmark_filter=GjkEpaWarm --benchmark_min_time=0.01
//
// Arg: number of objects.
#include <benchmark/benchmark.h>

#include <cstdint>
#include <unordered_map>
#include <vector>

#include "hbp/hybrid_broadphase.hpp"
#include "hbp/narrow/epa.hpp"
#include "hbp/narrow/gjk.hpp"
#include "hbp/narrow/intersect.hpp"
#include "hbp/scenario.hpp"

namespace {

using hbp::narrow::Convex;
using hbp::narrow::V3;

struct EpaCase {
  Convex a, b;
  hbp::narrow::Simplex simplex;
  hbp::narrow::Coherence warm;  // last frame's contact normal (contact = false: none)
};

bool has_closed_form(const Convex& a, const Convex& b) {
  const bool box_a = a.kind == hbp::ShapeKind::Cuboid, box_b = b.kind == hbp::ShapeKind::Cuboid;
  const bool sph_a = a.is_true_sphere(), sph_b = b.is_true_sphere();
  return (box_a && box_b) || (sph_a && sph_b) || (box_a && sph_b) || (sph_a && box_b);
}

const std::vector<EpaCase>& cases(std::uint32_t n) {
  static std::unordered_map<std::uint32_t, std::vector<EpaCase>> all;
  auto it = all.find(n);
  if (it != all.end()) return it->second;
  hbp::ScenarioParams sp;
  sp.n = n;
  sp.seed = 0;
  sp.frames = 4;
  hbp::Scenario scene(sp);
  hbp::HybridBroadPhase bp(hbp::BroadPhaseOptions{.engine = "sw", .threads = 1, .sorted = true});
  hbp::BoxArray boxes;
  std::unordered_map<std::uint64_t, hbp::narrow::Coherence> last;
  std::vector<EpaCase> out;
  for (int f = 0; f < 4; ++f) {
    if (f > 0) scene.step();
    scene.compute_boxes(boxes);
    const std::vector<hbp::Pair>& pairs = bp.update(boxes);
    std::unordered_map<std::uint64_t, hbp::narrow::Coherence> now;
    for (const hbp::Pair& p : pairs) {
      const Convex a = hbp::narrow::make_convex(scene.shapes()[p.a]);
      const Convex b = hbp::narrow::make_convex(scene.shapes()[p.b]);
      const double reach = a.radius + b.radius;
      if (hbp::narrow::norm2(b.centre - a.centre) > reach * reach || has_closed_form(a, b)) continue;
      const std::uint64_t key = (std::uint64_t{p.a} << 32) | p.b;
      hbp::narrow::GjkOptions go;
      go.boolean_only = true;
      const hbp::narrow::GjkResult g = hbp::narrow::gjk(a, b, go);
      if (!g.intersecting) continue;
      hbp::narrow::Hit hit;
      hbp::narrow::Coherence learned;
      const auto w = last.find(key);
      const hbp::narrow::Coherence* warm = w != last.end() ? &w->second : nullptr;
      if (!hbp::narrow::intersect(a, b, &hit, hbp::NarrowMethod::Auto, warm, &learned)) continue;
      now[key] = learned;
      if (f == 3) out.push_back({a, b, g.simplex, warm ? *warm : hbp::narrow::Coherence{}});
    }
    last.swap(now);
  }
  return all[n] = std::move(out);
}

// Not inlined: callgrind's --toggle-collect='*run_epa*' counts only this.
[[gnu::noinline]] std::int64_t run_epa(const std::vector<EpaCase>& cs) {
  hbp::narrow::EpaOptions eo;
  eo.rel_tolerance = hbp::narrow::kContactDepthTolerance;
  std::int64_t iterations = 0;
  for (const EpaCase& c : cs) {
    const hbp::narrow::EpaResult r = hbp::narrow::epa(c.a, c.b, c.simplex, eo);
    benchmark::DoNotOptimize(r.depth);
    iterations += r.iterations;
  }
  return iterations;
}

void BM_EpaCold(benchmark::State& state) {
  const auto& cs = cases(static_cast<std::uint32_t>(state.range(0)));
  std::int64_t iterations = 0;
  for (auto _ : state) iterations = run_epa(cs);
  state.SetItemsProcessed(state.iterations() * static_cast<std::int64_t>(cs.size()));
  state.counters["pairs"] = static_cast<double>(cs.size());
  state.counters["iter_per_pair"] = static_cast<double>(iterations) / static_cast<double>(cs.size());
  hbp::narrow::EpaOptions eo;
  eo.rel_tolerance = hbp::narrow::kContactDepthTolerance;
  int unconverged = 0, notok = 0, sep = 0;
  for (const EpaCase& c : cs) {
    const hbp::narrow::EpaResult r = hbp::narrow::epa(c.a, c.b, c.simplex, eo);
    unconverged += !r.converged;
    notok += !r.ok;
    sep += r.separated;
  }
  state.counters["unconverged"] = unconverged;
  state.counters["notok"] = notok;
  state.counters["separated"] = sep;
}

// GJK + EPA through intersect(), with last frame's normal (the path
// NarrowPhase takes for these pairs in steady state).
// Not inlined: callgrind's --toggle-collect='*run_warm*' counts only this.
[[gnu::noinline]] void run_warm(const std::vector<EpaCase>& cs) {
  for (const EpaCase& c : cs) {
    hbp::narrow::Hit hit;
    hbp::narrow::Coherence learned;
    const bool r =
        hbp::narrow::intersect(c.a, c.b, &hit, hbp::NarrowMethod::Auto, c.warm.contact ? &c.warm : nullptr, &learned);
    benchmark::DoNotOptimize(r);
    benchmark::DoNotOptimize(hit.depth);
  }
}

void BM_GjkEpaWarm(benchmark::State& state) {
  const auto& cs = cases(static_cast<std::uint32_t>(state.range(0)));
  for (auto _ : state) run_warm(cs);
  state.SetItemsProcessed(state.iterations() * static_cast<std::int64_t>(cs.size()));
  state.counters["pairs"] = static_cast<double>(cs.size());
}

BENCHMARK(BM_EpaCold)->Arg(20000)->Unit(benchmark::kMillisecond);
BENCHMARK(BM_GjkEpaWarm)->Arg(20000)->Unit(benchmark::kMillisecond);

}  // namespace
