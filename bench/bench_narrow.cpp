// SPDX-License-Identifier: MIT
// Narrow-phase throughput, single thread (pairs per second per core), for
// each kind combination: random pairs with the paper's sizes (25-75 m),
// random orientations, half placed near touching (see ShapePairGenerator).
//
//   bench_narrow --benchmark_min_time=0.2s
//
// Args: kind a, kind b (0 sphere, 1 cuboid, 2 cylinder, 3 cone).
#include <benchmark/benchmark.h>

#include <string>
#include <vector>

#include "hbp/narrow/narrow_phase.hpp"
#include "hbp/benchdata/random_pairs.hpp"

namespace {

struct Batch {
  std::vector<hbp::Shape> shapes;
  std::vector<hbp::Pair> pairs;
};

Batch make_batch(hbp::ShapeKind a, hbp::ShapeKind b, std::size_t n) {
  hbp::ShapePairGenerator gen(99);
  Batch batch;
  for (std::size_t i = 0; i < n; ++i) {
    const hbp::ShapePair p = gen.next(a, b);
    const auto ia = static_cast<std::uint32_t>(batch.shapes.size());
    batch.shapes.push_back(p.a);
    batch.shapes.push_back(p.b);
    batch.pairs.push_back({ia, ia + 1});
  }
  return batch;
}

void run(benchmark::State& state, hbp::NarrowMethod method, bool contacts) {
  const auto ka = static_cast<hbp::ShapeKind>(state.range(0));
  const auto kb = static_cast<hbp::ShapeKind>(state.range(1));
  const Batch batch = make_batch(ka, kb, 2048);
  const hbp::NarrowPhase narrow({.method = method, .contacts = contacts});
  std::vector<hbp::Contact> out;
  out.reserve(batch.pairs.size());
  std::size_t hits = 0;
  for (auto _ : state) {
    out.clear();
    hits = narrow.process(batch.shapes, batch.pairs.data(), batch.pairs.size(), out);
    benchmark::DoNotOptimize(out.data());
  }
  state.SetItemsProcessed(static_cast<std::int64_t>(state.iterations() * batch.pairs.size()));
  state.counters["hit_rate"] = static_cast<double>(hits) / static_cast<double>(batch.pairs.size());
  state.SetLabel(std::string(hbp::shape_kind_name(ka)) + "-" + hbp::shape_kind_name(kb));
}

void BM_NarrowContacts(benchmark::State& state) { run(state, hbp::NarrowMethod::Auto, true); }
void BM_NarrowBoolean(benchmark::State& state) { run(state, hbp::NarrowMethod::Auto, false); }
void BM_NarrowLibccdGjkEpa(benchmark::State& state) { run(state, hbp::NarrowMethod::LibccdGjkEpa, true); }

void kind_pairs(benchmark::internal::Benchmark* b) {
  for (int i = 0; i < 4; ++i)
    for (int j = i; j < 4; ++j) b->Args({i, j});
}

BENCHMARK(BM_NarrowContacts)->Apply(kind_pairs)->Unit(benchmark::kMicrosecond);
BENCHMARK(BM_NarrowBoolean)->Apply(kind_pairs)->Unit(benchmark::kMicrosecond);
BENCHMARK(BM_NarrowLibccdGjkEpa)->Apply(kind_pairs)->Unit(benchmark::kMicrosecond);

}  // namespace
