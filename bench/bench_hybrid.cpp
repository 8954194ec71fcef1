// SPDX-License-Identifier: MIT
// The hybrid system on the paper's scene: median time per frame of
// HybridBroadPhase::update (scene integration excluded), with partition and
// engine time as counters; the k-d partition's from-scratch build (what a
// rebuild frame paid on warm buffers; now only the first frame pays it); a
// rebuild spread over frames; and the two software kernels per cell
// size.
//
//   bench_hybrid --benchmark_filter=Paper --benchmark_repetitions=5
#include <benchmark/benchmark.h>
#include <tbb/task_arena.h>

#include <algorithm>
#include <chrono>
#include <map>
#include <memory>

#include "hbp/hybrid_broadphase.hpp"
#include "hbp/kd_partition.hpp"
#include "hbp/scenario.hpp"
#include "hbp/task_system.hpp"
#include "paper_frames.hpp"
#include "hbp/software_engine.hpp"

namespace {

const std::vector<hbp::BoxArray>& paper_frames(std::uint32_t n) { return hbp::bench::paper_frames(n, 8); }

void run_paper_frames(benchmark::State& state, hbp::TaskSystem* tasks) {
  const auto n = static_cast<std::uint32_t>(state.range(0));
  const auto threads = static_cast<unsigned>(state.range(1));
  const auto& frames = paper_frames(n);
  hbp::HybridBroadPhase bp({.engine = "sw", .threads = threads, .sorted = false, .task_system = tasks});
  for (const auto& f : frames) bp.update(f);  // build and warm the tree
  std::size_t k = 0;
  double partition = 0, engine = 0;
  for (auto _ : state) {
    const auto& pairs = bp.update(frames[k++ % frames.size()]);
    benchmark::DoNotOptimize(pairs.data());
    partition += bp.stats().partition_ms;
    engine += bp.stats().engine_ms;
  }
  const auto iters = static_cast<double>(state.iterations());
  state.counters["partition_ms"] = partition / iters;
  state.counters["engine_ms"] = engine / iters;
  state.counters["pairs"] = static_cast<double>(bp.stats().pairs);
  state.counters["cells"] = bp.stats().cells;
  state.counters["dup"] = bp.stats().duplication;
  state.SetItemsProcessed(state.iterations() * n);
}
void PaperFrame(benchmark::State& state) { run_paper_frames(state, nullptr); }
BENCHMARK(PaperFrame)
    ->ArgsProduct({{1000, 10000, 100000, 1024000}, {1, 2}})
    ->ArgNames({"n", "threads"})
    ->Unit(benchmark::kMillisecond)
    ->UseRealTime();

// The same frames on an engine's task system (hbp/task_system.hpp): the
// library's TbbTaskSystem of `threads` threads, its own arena, against
// PaperFrame's built-in arena (the same work, through the task door).
void PaperFrameTaskSystem(benchmark::State& state) {
  hbp::TbbTaskSystem tasks(static_cast<unsigned>(state.range(1)));
  run_paper_frames(state, &tasks);
}
BENCHMARK(PaperFrameTaskSystem)
    ->ArgsProduct({{100000, 1024000}, {1, 2}})
    ->ArgNames({"n", "threads"})
    ->Unit(benchmark::kMillisecond)
    ->UseRealTime();

// The from-scratch build of the partition on warm buffers (a rebuild frame's
// partition stage): the sweep engine's x weight, cell limit 1,024.
void PaperRebuild(benchmark::State& state) {
  const auto n = static_cast<std::uint32_t>(state.range(0));
  const auto threads = static_cast<int>(state.range(1));
  const auto& frames = paper_frames(n);
  hbp::KdPartition partition(1024, 0.5f);
  tbb::task_arena arena(threads);
  arena.execute([&] { partition.update(frames[0]); });  // buffers touched once
  std::size_t k = 0;
  for (auto _ : state) {
    partition.reset();
    arena.execute([&] { partition.update(frames[k++ % frames.size()]); });
  }
  state.counters["cells"] = partition.stats().cells;
  state.counters["dup"] = partition.stats().duplication;
  state.SetItemsProcessed(state.iterations() * n);
}
BENCHMARK(PaperRebuild)
    ->ArgsProduct({{100000, 1024000}, {1, 2}})
    ->ArgNames({"n", "threads"})
    ->Unit(benchmark::kMillisecond)
    ->UseRealTime();

// The same from-scratch build on the pair-dense scenes
// (`hbp scene gen --kind clustered|flat --n 1000000 --seed 3`: 1.8-2.3
// entries an object against the paper scene's 1.28): kind 0 clustered,
// 1 flat; frame 0 of each, warm buffers.
const hbp::BoxArray& dense_frame(hbp::ScenarioKind kind, std::uint32_t n) {
  static std::map<std::pair<int, std::uint32_t>, hbp::BoxArray> cache;
  auto& frame = cache[{static_cast<int>(kind), n}];
  if (frame.size() == 0) {
    hbp::ScenarioParams p;
    p.kind = kind;
    p.n = n;
    p.seed = 3;
    hbp::Scenario scene(p);
    scene.compute_boxes(frame);
  }
  return frame;
}

void DenseRebuild(benchmark::State& state) {
  const auto kind = state.range(0) == 0 ? hbp::ScenarioKind::Clustered : hbp::ScenarioKind::Flat;
  const auto n = static_cast<std::uint32_t>(state.range(1));
  const auto threads = static_cast<int>(state.range(2));
  const hbp::BoxArray& frame = dense_frame(kind, n);
  hbp::KdPartition partition(1024, 0.5f);
  tbb::task_arena arena(threads);
  arena.execute([&] { partition.update(frame); });  // buffers touched once
  for (auto _ : state) {
    partition.reset();
    arena.execute([&] { partition.update(frame); });
  }
  state.counters["cells"] = partition.stats().cells;
  state.counters["dup"] = partition.stats().duplication;
  state.SetItemsProcessed(state.iterations() * n);
}
BENCHMARK(DenseRebuild)
    ->ArgsProduct({{0, 1}, {1000000}, {1, 2}})
    ->ArgNames({"flat", "n", "threads"})
    ->Unit(benchmark::kMillisecond)
    ->UseRealTime();

// A rebuild spread over frames (the partition stage only, 2 threads when
// asked): the paper scene's frames 0-3, then its frames 4-7 again and again
// with every box grown by 80 m in y and z (duplication past the rebuild
// rule: the tree is rebuilt in subtrees of the default budget over the next
// frames). Counters: the frame of the growth itself and the next, the median partition
// update of the later grown frames with no rebuild in them and of those
// rebuilding subtrees, the slowest of those, how many frames the rebuild
// took; wall time per frame (std::chrono), one scenario per iteration.
void PaperSpreadRebuild(benchmark::State& state) {
  const auto n = static_cast<std::uint32_t>(state.range(0));
  const auto threads = static_cast<int>(state.range(1));
  const auto& frames = paper_frames(n);
  std::vector<hbp::BoxArray> grown;
  for (std::size_t f = 4; f < frames.size(); ++f) {
    grown.emplace_back();
    for (std::uint32_t i = 0; i < frames[f].size(); ++i) {
      hbp::Aabb a = frames[f].get(i);
      a.max[1] += 80.0f, a.max[2] += 80.0f;
      grown.back().push_back(a);
    }
  }
  hbp::KdPartition partition(1024, 0.5f);
  tbb::task_arena arena(threads);
  std::vector<double> quiet, rebuilding;
  for (auto _ : state) {
    partition.reset();
    quiet.clear();
    rebuilding.clear();
    for (int f = 0; f < 4; ++f) arena.execute([&] { partition.update(frames[static_cast<std::size_t>(f)]); });
    for (int f = 0; f < 96; ++f) {
      const auto t0 = std::chrono::steady_clock::now();
      arena.execute([&] { partition.update(grown[static_cast<std::size_t>(f) % grown.size()]); });
      const double ms = std::chrono::duration<double, std::milli>(std::chrono::steady_clock::now() - t0).count();
      if (f > 1) (partition.stats().rebuilt_subtrees > 0 ? rebuilding : quiet).push_back(ms);
      // The growth frame (every object changes cells) and the next one (the
      // second entry buffer grows into fresh pages; its first subtree too).
      else state.counters[f == 0 ? "growth_frame_ms" : "after_growth_ms"] = ms;
    }
  }
  std::sort(quiet.begin(), quiet.end());
  state.counters["quiet_median_ms"] = quiet.empty() ? 0.0 : quiet[quiet.size() / 2];
  std::vector<double> r = rebuilding;
  std::sort(r.begin(), r.end());
  state.counters["rebuild_median_ms"] = r.empty() ? 0.0 : r[r.size() / 2];
  state.counters["rebuild_max_ms"] = rebuilding.empty() ? 0.0 : *std::max_element(rebuilding.begin(), rebuilding.end());
  state.counters["rebuild_frames"] = static_cast<double>(rebuilding.size());
  state.counters["dup"] = partition.stats().duplication;
}
BENCHMARK(PaperSpreadRebuild)
    ->ArgsProduct({{100000, 1024000}, {1, 2}})
    ->ArgNames({"n", "threads"})
    ->Unit(benchmark::kMillisecond)
    ->Iterations(1)
    ->UseRealTime();

// One cell of the paper scene's density: sweep vs all-pairs by cell size.
void CellKernel(benchmark::State& state) {
  const auto size = static_cast<std::uint32_t>(state.range(0));
  const bool sweep = state.range(1) == 1;
  hbp::ScenarioParams p;
  p.n = size;
  hbp::Scenario scene(p);
  hbp::BoxArray boxes;
  scene.compute_boxes(boxes);
  hbp::SoftwareEngine engine(sweep ? hbp::SoftwareEngine::Kernel::Sweep : hbp::SoftwareEngine::Kernel::AllPairs);
  std::vector<hbp::Pair> out;
  for (auto _ : state) {
    out.clear();
    engine.find_pairs(boxes, out);
    benchmark::DoNotOptimize(out.data());
  }
  state.SetLabel(std::string(sweep ? "sweep" : "all-pairs") + " " + hbp::SoftwareEngine::isa());
  state.SetItemsProcessed(state.iterations() * size);
}
BENCHMARK(CellKernel)
    ->ArgsProduct({{64, 256, 1024, 4096}, {0, 1}})
    ->ArgNames({"cell", "sweep"})
    ->Unit(benchmark::kMicrosecond);

}  // namespace
