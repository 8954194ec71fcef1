// SPDX-License-Identifier: MIT
// The frame's pair list sorted by (a, b): the
// serial radix sort (sort_pairs) beside the parallel sort
// (src/pipeline/parallel_pair_sort) on the same list, and the hybrid
// system's default sorted frame with its sort_ms stage.
//
//   PairSort/<n>/<threads>/<method>: the paper scene's pair list at n
//     objects, in the order the hybrid system produces it unsorted (cell
//     order), sorted by method 0 = sort_pairs (serial, what main does),
//     1 = parallel_sort_pairs on a `threads` arena, 2 = the parallel path
//     forced whatever the size and thread count (to place the serial
//     threshold, and to see the split on one thread). Manual time: the sort
//     only (the copy of the input before each iteration is not timed).
//   PairSortBuckets/<n>/<target>: the parallel sort on 2 threads with
//     buckets of about `target` pairs (the default is 8,192).
//   SortedFrame/<n>/<threads>: HybridBroadPhase with its defaults (sorted
//     output), frames of the paper scene; counters: mean sort_ms and
//     wall_ms of the frames (the stats of HybridBroadPhase).
//
//   bench_pair_sort --benchmark_filter='PairSort/1024000' --benchmark_repetitions=5
#include <benchmark/benchmark.h>
#include <tbb/task_arena.h>

#include <chrono>
#include <map>
#include <vector>

#include "hbp/hybrid_broadphase.hpp"
#include "hbp/pair.hpp"
#include "hbp/scenario.hpp"
#include "paper_frames.hpp"
#include "pipeline/parallel_pair_sort.hpp"

namespace {

using hbp::Pair;

const std::vector<hbp::BoxArray>& paper_frames(std::uint32_t n) { return hbp::bench::paper_frames(n, 4); }

// The unsorted pair list of the paper's frame at n objects (cell order).
const std::vector<Pair>& paper_pairs(std::uint32_t n) {
  static std::map<std::uint32_t, std::vector<Pair>> cache;
  auto& pairs = cache[n];
  if (pairs.empty()) {
    hbp::HybridBroadPhase bp({.engine = "sw", .threads = 2, .sorted = false});
    for (const auto& f : paper_frames(n)) pairs = bp.update(f);
  }
  return pairs;
}

void PairSort(benchmark::State& state) {
  const auto n = static_cast<std::uint32_t>(state.range(0));
  const auto threads = static_cast<int>(state.range(1));
  const auto method = state.range(2);
  const std::vector<Pair>& input = paper_pairs(n);
  tbb::task_arena arena(threads);
  hbp::detail::PairSortLimits forced;
  forced.parallel_from = 0;
  forced.serial_on_one_thread = false;
  std::vector<Pair> pairs, scratch;
  for (auto _ : state) {
    pairs = input;
    const auto t0 = std::chrono::steady_clock::now();
    if (method == 0)
      hbp::sort_pairs(pairs, scratch);
    else if (method == 1)
      hbp::parallel_sort_pairs(pairs, scratch, arena);
    else
      hbp::detail::parallel_sort_pairs(pairs, scratch, arena, forced);
    state.SetIterationTime(std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count());
    benchmark::DoNotOptimize(pairs.data());
  }
  state.counters["pairs"] = static_cast<double>(input.size());
  state.SetItemsProcessed(state.iterations() * static_cast<std::int64_t>(input.size()));
}
BENCHMARK(PairSort)
    ->ArgsProduct({{10000, 20000, 50000, 100000, 1024000}, {1, 2}, {0, 1, 2}})
    ->ArgNames({"n", "threads", "method"})
    ->Unit(benchmark::kMillisecond)
    ->UseManualTime();

// The parallel path on 2 threads with buckets of about `target` pairs (the
// default: PairSortLimits::bucket_target).
void PairSortBuckets(benchmark::State& state) {
  const std::vector<Pair>& input = paper_pairs(static_cast<std::uint32_t>(state.range(0)));
  tbb::task_arena arena(2);
  hbp::detail::PairSortLimits limits;
  limits.bucket_target = static_cast<std::size_t>(state.range(1));
  std::vector<Pair> pairs, scratch;
  for (auto _ : state) {
    pairs = input;
    const auto t0 = std::chrono::steady_clock::now();
    hbp::detail::parallel_sort_pairs(pairs, scratch, arena, limits);
    state.SetIterationTime(std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count());
    benchmark::DoNotOptimize(pairs.data());
  }
}
BENCHMARK(PairSortBuckets)
    ->ArgsProduct({{1024000}, {2048, 4096, 8192, 16384, 32768}})
    ->ArgNames({"n", "target"})
    ->Unit(benchmark::kMillisecond)
    ->UseManualTime();

void SortedFrame(benchmark::State& state) {
  const auto n = static_cast<std::uint32_t>(state.range(0));
  const auto threads = static_cast<unsigned>(state.range(1));
  const auto& frames = paper_frames(n);
  hbp::HybridBroadPhase bp({.engine = "sw", .threads = threads});
  for (const auto& f : frames) bp.update(f);  // build and warm the tree
  std::size_t k = 0;
  double sort = 0, wall = 0;
  for (auto _ : state) {
    const auto& pairs = bp.update(frames[k++ % frames.size()]);
    benchmark::DoNotOptimize(pairs.data());
    sort += bp.stats().sort_ms;
    wall += bp.stats().wall_ms;
  }
  const auto iters = static_cast<double>(state.iterations());
  state.counters["sort_ms"] = sort / iters;
  state.counters["wall_ms"] = wall / iters;
  state.counters["pairs"] = static_cast<double>(bp.stats().pairs);
}
BENCHMARK(SortedFrame)
    ->ArgsProduct({{100000, 1024000}, {1, 2}})
    ->ArgNames({"n", "threads"})
    ->Unit(benchmark::kMillisecond)
    ->UseRealTime();

}  // namespace
