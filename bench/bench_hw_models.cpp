// SPDX-License-Identifier: MIT
// Speed of the microarchitecture models: the cycle-level simulators
// (simulated comparator slots per second) against the path benchmarks use
// (hardware-order scalar all-pairs for the pairs, analytic cycles).
#include <benchmark/benchmark.h>

#include <vector>

#include "hbp/hw/analytic_cycles.hpp"
#include "hbp/hw/area_efficient_model.hpp"
#include "hbp/hw/hw_cell_engines.hpp"
#include "hbp/hw/many_object_model.hpp"
#include "hbp/scenario.hpp"

namespace {

hbp::BoxArray paper_boxes(std::uint32_t n) {
  hbp::ScenarioParams p;
  p.n = n;
  hbp::Scenario s(p);
  hbp::BoxArray boxes;
  s.compute_boxes(boxes);
  return boxes;
}

template <class Model>
void simulate(benchmark::State& state) {
  const auto n = static_cast<std::uint32_t>(state.range(0));
  const hbp::BoxArray boxes = paper_boxes(n);
  Model model;  // paper configuration: m = 16, depth 1024
  std::vector<hbp::Pair> pairs;
  std::uint64_t slots = 0, cycles = 0;
  for (auto _ : state) {
    pairs.clear();
    const hbp::hw::Counters k = model.run(boxes, pairs);
    slots += k.comparator_slots;
    cycles += k.cycles.total();
    benchmark::DoNotOptimize(pairs.data());
  }
  state.counters["slots/s"] = benchmark::Counter(static_cast<double>(slots), benchmark::Counter::kIsRate);
  state.counters["cycles/s"] = benchmark::Counter(static_cast<double>(cycles), benchmark::Counter::kIsRate);
}

void BM_SimulateAreaEfficient(benchmark::State& state) { simulate<hbp::hw::AreaEfficientModel>(state); }
void BM_SimulateManyObject(benchmark::State& state) { simulate<hbp::hw::ManyObjectModel>(state); }
BENCHMARK(BM_SimulateAreaEfficient)->Arg(256)->Arg(1024)->Unit(benchmark::kMillisecond);
BENCHMARK(BM_SimulateManyObject)->Arg(1024)->Arg(4096)->Unit(benchmark::kMillisecond);

// What full benchmarks pay per cell: the engine's fast path.
void BM_FastPathEngine(benchmark::State& state) {
  const auto n = static_cast<std::uint32_t>(state.range(0));
  const hbp::BoxArray boxes = paper_boxes(n);
  auto engine = state.range(1) == 0 ? hbp::hw::make_area_efficient_engine() : hbp::hw::make_many_object_engine();
  std::vector<hbp::Pair> pairs;
  for (auto _ : state) {
    pairs.clear();
    benchmark::DoNotOptimize(engine->find_pairs(boxes, pairs).cycles);
  }
  const double tests = static_cast<double>(n) * (n - 1) / 2;
  state.counters["pair_tests/s"] =
      benchmark::Counter(tests * static_cast<double>(state.iterations()), benchmark::Counter::kIsRate);
  state.SetLabel(engine->name());
}
BENCHMARK(BM_FastPathEngine)->Args({1024, 0})->Args({1024, 1})->Unit(benchmark::kMicrosecond);

// The analytic cycle function alone (closed form).
void BM_AnalyticCycles(benchmark::State& state) {
  const hbp::hw::ModelConfig cfg;
  std::uint64_t n = 1;
  for (auto _ : state) {
    benchmark::DoNotOptimize(hbp::hw::analytic_cycles(hbp::hw::Design::AreaEfficient, n, cfg).total() +
                             hbp::hw::analytic_cycles(hbp::hw::Design::ManyObject, n, cfg).total());
    n = n % 16384 + 1;
  }
}
BENCHMARK(BM_AnalyticCycles);

}  // namespace
